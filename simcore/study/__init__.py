"""Helpers of the parameter study that work on whole runs: the compliant zoom on an impact of a
run (:mod:`.zoom`) and the repair of a study's damaged outputs (:mod:`.repair`)."""

# Parameter study of the SKF-6012 ball bearing in a crank-slider.
#
#   snakemake -j2                                   default study (config/config.yaml)
#   snakemake -j2 --configfile config/smoke.yaml    2 x 2 grid of short runs, both models (CI)
#
# Every study key, how to sweep any setting, batching and study.max_runs: config/README.md.
#   snakemake --report report.html                  report with the figures
#
# The rules live in workflow/rules/; the jobs call functions of simcore and analysis.

import sys

from snakemake.utils import min_version

min_version("8.0")


# the study's base settings, which a --configfile is merged over (workflow/rules/common.smk
# stops a study whose working folder lacks it)
BASE_CONFIG = "config/config.yaml"


configfile: BASE_CONFIG


include: "workflow/rules/common.smk"
include: "workflow/rules/terminal.smk"


report: "workflow/report/workflow.rst"


rule all:
    default_target: True
    input:
        SUMMARY_NC,
        FIGURES,


include: "workflow/rules/simulate.smk"
include: "workflow/rules/analysis.smk"
include: "workflow/rules/figures.smk"


# Before the jobs: --forceall redoes every run (workflow/rules/common.smk), and the Numba
# kernels are compiled once (workflow/rules/terminal.smk).
onstart:
    mark_redo()
    warm_numba_cache()


onsuccess:
    for line in failed_points(SUMMARY_NC):
        print(f"WARNING: failed run (marked missing in {SUMMARY_NC}): {line}", file=sys.stderr)
    freeze_heap()

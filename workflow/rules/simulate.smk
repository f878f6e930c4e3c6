# Simulations and their impact tables, one file of each per run (docs/study.md, "Files"):
#   results/runs/<params>.nc, results/impacts/<params>.nc                  nonsmooth runs
#   results/runs_compliant/<params>.nc, results/impacts_compliant/<params>.nc  compliant twins
# One job runs one batch of about study.batch_seconds of estimated work (simcore.study.plan)
# and makes each run's impact table (filter, Flores forces, compliant zooms; docs/forces.md)
# from the run in memory, in the same process; its output is the batch's marker, written last.
# A run whose solver does not converge is recorded as a "failed" marker file with an empty
# impact table, so that the rest of the study goes on (see the README).


rule simulate:
    output:
        MARKER,
    log:
        simulate=f"{LOGS}/simulate/{{batch}}.log",
        impacts=f"{LOGS}/impacts/{{batch}}.log",
    benchmark:
        f"{LOGS}/simulate/{{batch}}.benchmark.tsv"
    params:
        runs=batch_runs,
        axes=list(AXES),
    threads: 1
    priority: batch_priority  # longest batches first (workflow/rules/common.smk)
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/simulate.py"

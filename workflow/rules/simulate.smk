# Simulations and their impact tables, one file of each per grid point:
# results/runs/<params>.nc and results/impacts/<params>.nc. One job runs the points of one batch
# (study.batch_axes) and makes each run's impact table (filter, Flores forces, compliant zooms;
# docs/forces.md) from the run in memory, in the same process. A run whose solver does not
# converge is recorded as a "failed" marker file with an empty impact table, so that the rest of
# the study goes on (see the README).


rule simulate:
    output:
        runs=batch_files("runs"),
        impacts=batch_files("impacts"),
    log:
        simulate=f"{LOGS}/simulate/{BATCH_NAME}.log",
        impacts=f"{LOGS}/impacts/{BATCH_NAME}.log",
    benchmark:
        f"{LOGS}/simulate/{BATCH_NAME}.benchmark.tsv"
    params:
        points=batch_points,
        configs=batch_configs,
        keep=config["study"]["keep"],
        analysis=config["analysis"],
    threads: 1
    priority: batch_priority  # longest batches first (workflow/rules/common.smk)
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/simulate.py"

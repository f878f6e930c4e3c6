# Simulations, one file per grid point: results/runs/<params>.nc. One job runs
# the points of one batch (study.batch_axes). A run whose solver does not converge is recorded
# as a "failed" marker file, so that the rest of the study goes on (see the README).


rule simulate:
    output:
        batch_files("runs"),
    log:
        f"{LOGS}/simulate/{BATCH_NAME}.log",
    benchmark:
        f"{LOGS}/simulate/{BATCH_NAME}.benchmark.tsv"
    params:
        points=batch_points,
        configs=batch_configs,
        keep=config["study"]["keep"],
    threads: 1
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/simulate.py"


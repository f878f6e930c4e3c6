# Filter and forces per run (docs/forces.md; one job per batch of runs, as simulate), then one summary over the grid (docs/study.md).


rule impacts:
    input:
        runs=batch_files("runs"),
    output:
        batch_files("impacts"),
    log:
        f"{LOGS}/impacts/{BATCH_NAME}.log",
    benchmark:
        f"{LOGS}/impacts/{BATCH_NAME}.benchmark.tsv"
    params:
        analysis=config["analysis"],
    threads: 1
    resources:
        runtime=10,
        mem_mb=1000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/impacts.py"


rule summarize:
    input:
        runs=ALL_RUNS,
        impacts=ALL_IMPACTS,
    output:
        SUMMARY_NC,
    log:
        f"{LOGS}/summarize.log",
    benchmark:
        f"{LOGS}/summarize.benchmark.tsv"
    params:
        scheduler=config["study"]["dask_scheduler"],
        analysis=config["analysis"],
        revolutions=config["study"]["revolutions"],
    threads: 2
    resources:
        runtime=30,
        mem_mb=4000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/summarize.py"

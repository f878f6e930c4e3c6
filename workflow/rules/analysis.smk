# One summary over the grid (docs/study.md); the impact tables it reads come from the simulate
# jobs (workflow/rules/simulate.smk).


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

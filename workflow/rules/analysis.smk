# One summary over the grid and both contact models (docs/study.md); the run files and impact
# tables it reads are made by the simulate jobs (workflow/rules/simulate.smk), whose markers
# are its inputs.


rule summarize:
    input:
        ALL_MARKERS,
    output:
        SUMMARY_NC,
    log:
        f"{LOGS}/summarize.log",
    benchmark:
        f"{LOGS}/summarize.benchmark.tsv"
    params:
        runs=RUN_FILES,
        impacts=TABLE_FILES,
        axes=AXIS_NAMES,
        scheduler=config["study"]["dask_scheduler"],
        analysis=config["analysis"],
        own_settings=SWEPT_ANALYSIS,
        fixed_model=FIXED_MODEL,
        revolutions=config["study"]["revolutions"],
        reference=REFERENCE_COORDS,
    threads: 2
    resources:
        runtime=30,
        mem_mb=4000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/summarize.py"

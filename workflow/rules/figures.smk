# Figures of the reference run (the grid point nearest to the model section) and of the study.


rule figures:
    input:
        run=f"{RES}/runs/{REFERENCE_NAME}.nc",
        impacts=f"{RES}/impacts/{REFERENCE_NAME}.nc",
        summary=SUMMARY_NC,
    output:
        report(
            directory(FIGURES),
            patterns=["{name}.png"],
            caption="../report/figures.rst",
            category="Figures",
            labels={"figure": "{name}"},
        ),
    log:
        f"{LOGS}/figures.log",
    benchmark:
        f"{LOGS}/figures.benchmark.tsv"
    params:
        analysis=config["analysis"],
        reference=REFERENCE,
    threads: 2  # the figures shared by two processes (workflow/scripts/figures.py)
    resources:
        runtime=10,
        mem_mb=2000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/figures.py"

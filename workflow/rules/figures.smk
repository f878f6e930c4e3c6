# Figures of the reference run (the grid point nearest to the model section) and of the study.
#
# The reference run's figures are drawn by a job of their own as soon as its batch is simulated,
# while the other batches still run (they need no summary): the figures job at the end, on the
# critical path, then only draws the study's heat maps and moves the reference figures in.


rule reference_figures:
    input:
        REFERENCE_MARKER,
    output:
        temp(directory(REFERENCE_FIGURES)),
    log:
        f"{LOGS}/reference_figures.log",
    benchmark:
        f"{LOGS}/reference_figures.benchmark.tsv"
    params:
        analysis=config["analysis"],
        reference=REFERENCE,
        files=REFERENCE_FILES,
    threads: 1
    priority: 1000  # right after its batch, before the remaining simulate jobs
    resources:
        runtime=10,
        mem_mb=2000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/reference_figures.py"


rule figures:
    input:
        reference=REFERENCE_FIGURES,
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
        figure_axes=FIGURE_AXES,
        figure_fixed=FIGURE_FIXED,
        reference_coords=REFERENCE_COORDS,
        axes=AXIS_NAMES,
    threads: 2  # the study's heat maps shared by two processes (workflow/scripts/figures.py)
    resources:
        runtime=10,
        mem_mb=2000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/figures.py"

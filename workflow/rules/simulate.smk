# Simulations (SPEC section 5): one file per grid point, results/runs/<params>.nc. One job runs
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
    threads: 1
    resources:
        runtime=30,
        mem_mb=1000,
    conda:
        "../envs/sim.yaml"
    script:
        "../scripts/simulate.py"


# Before any job: compile (or load) the Numba kernels once, in one process, and say so. Not in
# dry runs; Snakemake runs onstart only when there is something to do.
def warm_numba_cache():
    import subprocess
    import time

    log = Path(LOGS, "warm_cache.log")
    log.parent.mkdir(parents=True, exist_ok=True)
    print("Numba: compiling the kernels once before the jobs start (1-3 min after an install "
          "or an update of simcore, a few seconds when cached) ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    with open(log, "w") as out:
        done = subprocess.run([sys.executable, str(Path(workflow.basedir, "workflow", "scripts",
                                                        "warm_cache.py"))],
                              stdout=out, stderr=subprocess.STDOUT)
    took = time.perf_counter() - start
    if done.returncode == 0:
        print(f"Numba: kernels ready ({took:.0f} s; details in {log})", file=sys.stderr,
              flush=True)
    else:
        print(f"WARNING: the Numba warm-up failed after {took:.0f} s (see {log}); each job "
              "will compile for itself", file=sys.stderr, flush=True)


onstart:
    warm_numba_cache()


class _TerseTerminal(logging.Filter):
    """Drop Snakemake's scheduling chatter from the terminal (the full log keeps it).

    Left: the job counts at the start, a progress line per finished job ("3 of 20 steps (15%)
    done"), the lines the jobs print (one per simulation batch, failed runs), warnings, errors
    and the end. With `quiet: [rules, host]` in profiles/default/ this makes a study's terminal
    output a screenful.
    """

    _DROP = ("Select jobs to execute", "Execute ", "Finished jobid", "Using shell:",
             "Assuming unrestricted shared filesystem", "Building DAG of jobs",
             "Conda environments: ignored", "Provided cores", "Rules claiming more threads")
    _STAMP = re.compile(r"^\[\w{3} \w{3} +\d+ [\d:]+ \d{4}\]$")

    _FINISHED = re.compile(r"^Finished jobid: \d+ \(Rule: (\w+)\)")
    _PROGRESS = re.compile(r"^\d+ of \d+ steps \(.*\) done$")
    _rule = None

    def filter(self, record):
        if record.levelno > logging.INFO:
            return True
        text = str(record.getMessage()).strip()
        finished = self._FINISHED.match(text)
        if finished:
            self._rule = finished.group(1)
        elif self._PROGRESS.match(text) and self._rule and not record.args:
            record.msg = f"{text}: {self._rule}"
            self._rule = None
        return not (text.startswith(self._DROP) or self._STAMP.match(text))


def _terse_terminal():
    from snakemake.logging import logger

    if not any(isinstance(f, _TerseTerminal) for f in logger.filters):
        logger.addFilter(_TerseTerminal())


_terse_terminal()

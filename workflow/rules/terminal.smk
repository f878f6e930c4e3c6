# The terminal during a study (functions only; included by the Snakefile): the Numba kernels
# are compiled once before the jobs start, and Snakemake's per-job chatter is left out of the
# terminal (the log under .snakemake/log/ keeps everything, each job's output is in logs/).


def warm_numba_cache():
    """Compile (or load) the Numba kernels once, in one process, and say so on the terminal.

    Called by the Snakefile's onstart: not in dry runs, and only when there is a job to run.
    Skipped when the warm-up already succeeded for these kernel sources (its stamp file,
    workflow/scripts/warm_cache.py): loading a warm cache in a process of its own took 2-3 s
    before the first job could start.
    """
    import subprocess
    import time

    log = Path(LOGS, "warm_cache.log")
    log.parent.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(Path(workflow.basedir, "workflow", "scripts")))
    try:
        from warm_cache import warm_stamp
    finally:
        sys.path.pop(0)
    if warm_stamp().exists():
        log.write_text(f"kernels already compiled for these sources ({warm_stamp()})\n")
        print("Numba: kernels cached", file=sys.stderr, flush=True)
        return
    print("Numba: compiling the kernels once before the jobs start (a minute or a few after an install "
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



class _TerseTerminal(logging.Filter):
    """Drop Snakemake's scheduling chatter from the terminal (the full log keeps it).

    Left: the job counts at the start, a progress line per finished job ("3 of 20 steps (15%)
    done"), the lines the jobs print (one per simulation batch, failed runs), warnings, errors
    and the end; the per-job blocks (inputs and outputs, kB of paths) only in a dry run.
    With `quiet: [host]` in profiles/default/ this makes a study's terminal output a screenful.
    """

    _DROP = ("Select jobs to execute", "Execute ", "Finished jobid", "Using shell:",
             "Assuming unrestricted shared filesystem", "Building DAG of jobs",
             "Conda environments: ignored", "Provided cores", "Rules claiming more threads")
    _STAMP = re.compile(r"^\[\w{3} \w{3} +\d+ [\d:]+ \d{4}\]$")

    def __init__(self, workflow):
        super().__init__()
        self.workflow = workflow

    def filter(self, record):
        # (the event of a record, as Snakemake's logger plugin interface defines it)
        from snakemake_interface_logger_plugins.common import LogEvent

        if record.levelno > logging.INFO:
            return True
        event = getattr(record, "event", None)
        job_info = event in (LogEvent.JOB_INFO, LogEvent.GROUP_INFO)
        if job_info and not self.workflow.dryrun:
            return False  # the job's inputs and outputs (kB of paths); a dry run lists them
        text = str(record.getMessage()).strip()
        return not (text.startswith(self._DROP) or self._STAMP.match(text))


def _terse_terminal():
    logger = logging.getLogger("snakemake.logging")  # Snakemake's terminal output
    if not any(isinstance(f, _TerseTerminal) for f in logger.filters):
        logger.addFilter(_TerseTerminal(workflow))


_terse_terminal()


def freeze_heap():
    """Freeze the objects of Snakemake's process (called last in the Snakefile's onsuccess):
    its shut-down skips them (start-up patch gc_freeze, simcore.startup.patches.freeze_heap).
    What Snakemake makes after this point is collected as usual."""
    from simcore.startup.patches import freeze_heap as freeze

    freeze()

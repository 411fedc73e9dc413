"""The sweep and the resonance map as Ray tasks: on all local cores, or on a cluster.

Each task calls the bound engine's sweep (mjstepper.sweep, src/tools/sweep.cc) on one speed, or one
(value, speed) of a map, with one thread; the driver puts the rows back in the command's order and
writes the command's files through the same writers. No experiment is written here: the rows are
the command's to the bit (tested). The whole command line is checked by the command's parser
before Ray starts. Every node needs this package (`pip install "mjstepper[ray]"`); the model's text
goes with the tasks (files it includes must be on every node: docs/ray.md).
"""
import sys

import numpy as np

from . import _engine, _experiments


def _ray_requirement():
    """The Ray the package's `ray` extra pins (pyproject.toml), e.g. "ray==2.60.0"."""
    from importlib import metadata
    for requirement in metadata.requires("mjstepper") or []:
        if requirement.replace(" ", "").endswith('extra=="ray"'):
            return requirement.split(";")[0].strip()
    return "ray"


def _import_ray(function):
    try:
        import ray
    except ModuleNotFoundError:
        raise ModuleNotFoundError(
            f"{function} runs on Ray, which is not installed: pip install \"{_ray_requirement()}\" "
            f"(the package's extra, as pip install \"mjstepper[ray]\" would give it, without "
            f"building mjstepper again); or run it on this machine's threads with "
            f"mjstepper.{function.split('.')[-1]}") from None
    return ray


def _task(function, model, text, speed, options):
    """One run on a node: the model at its path when the node has that very file (a local Ray, a
    shared folder), else its text in a temporary file (files it includes would then be missing)."""
    import os
    import tempfile

    import mjstepper  # on the node: loads the plugin into its mujoco
    run = getattr(mjstepper, function)
    try:
        with open(model, encoding="utf-8") as f:
            same = f.read() == text
    except OSError:
        same = False
    if same:
        table = run(model, speed, **options)
    else:
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, os.path.basename(model))
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
            table = run(path, speed, **options)
    return [(name, table.units[name], table[name].tolist()) for name in table.dtype.names]


def _run(function, model, runs, options, address, quiet, what):
    """Runs function(model, speed, threads=1, **options) for each (speed, extra options) in
    `runs` as Ray tasks; the rows in order."""
    model = _experiments.model_path(model)  # the file the command would read, on this machine
    ray = _import_ray(f"mjstepper.distributed.{what}")
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, logging_level="ERROR", log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(_task)
        with open(model, encoding="utf-8") as f:
            text = ray.put(f.read())
        pending = [remote.remote(function, model, text, speed,
                                 {**options, **extra, "threads": 1, "quiet": True})
                   for speed, extra in runs]
        order = {ref: i for i, ref in enumerate(pending)}
        results = [None] * len(pending)
        waiting = list(pending)
        while waiting:
            done, waiting = ray.wait(waiting, num_returns=1)
            for ref in done:
                results[order[ref]] = ray.get(ref)
            if not quiet:
                print(f"\r  ray {what}: {len(pending) - len(waiting)}/{len(pending)} runs",
                      end="" if waiting else "\n", file=sys.stderr, flush=True)
        return results
    finally:
        if started:
            ray.shutdown()


def _concatenate(parts, parameter=None):
    """One Table of the tasks' rows, in order, with their columns' names and units."""
    columns = [(name, unit, [v for part in parts for v in part[k][2]])
               for k, (name, unit, _) in enumerate(parts[0])]
    return _experiments.Table(columns, parameter=parameter)


def _write(args, table):
    """The command's files of `table` (its --out), through the command's writers."""
    _engine.write_outputs(args, {name: np.asarray(table[name], dtype=float).tolist()
                                 for name in table.dtype.names})


def sweep(model, speeds, *, address=None, out=None, quiet=False, **options):
    """mjstepper.sweep on Ray, one task per speed; the same Table and, with out=PREFIX, the same
    PREFIX.csv and PREFIX.png. `address`: a Ray cluster's (default: a local Ray on every core).
    Options as mjstepper.sweep (actuator, settle, measure, set, allow_coarse); quiet: no line of
    the tasks' progress (default False: shown)."""
    args = _experiments.sweep_args(model, speeds, out=out, **options)
    _experiments.check(args)
    runs = [(s, {}) for s in _engine.parse_speeds(_experiments.speeds_text(speeds))]
    table = _concatenate(_run("sweep", model, runs, options, address, quiet, "sweep"))
    if out is not None:
        _write(args, table)
    return table


def map(model, speeds, vary, *, address=None, out=None, quiet=False, **options):
    """mjstepper.map on Ray, one task per (value, speed); the same Table and files."""
    parameter, values = vary
    values = list(values)  # read twice below: a generator would be empty the second time
    vary = (parameter, values)
    args = _experiments.map_args(model, speeds, vary, out=out, **options)
    _experiments.check(args)
    speed_list = _engine.parse_speeds(_experiments.speeds_text(speeds))
    runs = [(s, {"vary": (parameter, [v])}) for v in values for s in speed_list]
    table = _concatenate(_run("map", model, runs, options, address, quiet, "map"),
                         parameter=parameter)
    if out is not None:
        _write(args, table)
    return table

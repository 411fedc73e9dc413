"""Fuzzes the Python front-end's arguments (issue 33, item 7) with atheris (libFuzzer for Python).

One input is decoded into a call of one experiment's argument builder, the function every public
experiment calls before it runs (mjstepper._experiments: run_args, sweep_args, map_args,
pullout_args, identify_args, resonance_test_args, size_args, attach_args), with Python values a
hostile or careless caller passes: None, bools, numpy scalars and arrays (broadcast views of 1e9
elements too), huge and negative integers, NaN and infinities, Fractions, Decimals, complex
numbers, str with control characters or a million characters, bytes, paths, nested and
self-containing lists, dicts with odd keys, ranges of 1e9 items, generators, objects whose
__float__ or __iter__ raises, and unknown keywords. The keywords come from each builder's own
signature, so a new option is fuzzed without touching this file. What the builders accept goes to
the command's own parser (mjstepper._experiments.check: parses, never runs); StepTimes gets the
same values.

Properties (a violation raises AssertionError, which atheris reports with the input):
  1. nothing but TypeError, ValueError or FileNotFoundError comes out (no OverflowError,
     AttributeError, RecursionError, MemoryError, SystemError, ...), but for the errors the
     caller's own objects raise, which pass through as they are;
  2. a message is at most 2 100 characters (the engine's kMaxMessage, 2 000 bytes, and the
     length it then gives) and has no control character but the newline;
  3. a TypeError names the argument (its Python name, as the caller wrote it);
  4. a ValueError of the parser speaks Python: no command-line option ("--settle") where the
     Python keyword exists;
  5. a built command line is a list of str;
  6. nothing is written: the working folder stays empty;
  7. (libFuzzer's -timeout) no input takes over 1 s.

Run with the installed package (tests/fuzz/run.sh python [-runs=N | SECONDS] installs atheris
into the wheel's venv and runs it; tests/python/wheel_test.sh runs it for 15 s):
    python tests/fuzz/python_fuzz.py -runs=1000000 -timeout=1 -rss_limit_mb=2048 CORPUS_DIR
"""
import decimal
import fractions
import inspect
import os
import pathlib
import re
import sys

import atheris

with atheris.instrument_imports(include=["mjstepper"]):
    import mjstepper
    from mjstepper import _experiments as ex

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = [os.path.join(ROOT, "models", n) for n in
          ("tsui_rigid.xml", "arm3.xml", "belt_axis.xml", "corexy.xml", "kim_foc_case1.xml")]

BUILDERS = {
    "run": (ex.run_args, ["model", "duration"]),
    "sweep": (ex.sweep_args, ["model", "speeds"]),
    "map": (ex.map_args, ["model", "speeds", "vary"]),
    "pullout": (ex.pullout_args, ["model", "speeds"]),
    "identify": (ex.identify_args, ["model", "speeds"]),
    "resonance_test": (ex.resonance_test_args, ["model", "axis", "out"]),
    "size": (ex.size_args, ["model", "move"]),
    "attach": (ex.attach_args, ["robot", "stepper", "out"]),
}
KEYWORDS = {name: [p for p in inspect.signature(f).parameters
                   if inspect.signature(f).parameters[p].kind == inspect.Parameter.KEYWORD_ONLY]
            for name, (f, _) in BUILDERS.items()}
# Every Python keyword of the command's options ("settle", "allow_coarse=True", ...).
PYTHON_WORDS = set(ex._keywords().values())
OPTION_WORDS = {option for option in ex._keywords()}

TEXTS = ["", "10:200:2.5rpm", "50:300:10mm/s", "1,2,3rad/s", "constant(100rpm)",
         "shaft=constant(100rpm)", "ramp(0rpm,200rpm,0.8s)", "shaft", "x", "y", "shoulder",
         "payload=2", "stiffness:belt=1e5", "shaft.damping=all", "--quiet", "--duration",
         "\x1b[2J", "a\x00b", "é" * 40, "30,0deg", "90deg/s", "600deg/s²", "settled", "aligned",
         "tmc2209", "17hs24_2104s", "nan", "inf", "-1", "1e309", "steps(/dev/zero)",
         "/dev/null", "/proc/self/mem", ".", "..", "/", "out/x", "shaped(" * 50]


class Raises:
    """An object whose conversions raise: __float__, __index__, __iter__, __len__, __str__."""

    def __init__(self, error):
        self.error = error

    def __float__(self):
        raise self.error

    def __index__(self):
        raise self.error

    def __iter__(self):
        raise self.error

    def __len__(self):
        raise self.error

    def __fspath__(self):
        raise self.error


def value(fdp, depth=0):
    kind = fdp.ConsumeIntInRange(0, 27)
    if kind == 0:
        return None
    if kind == 1:
        return fdp.ConsumeBool()
    if kind == 2:
        return np.bool_(fdp.ConsumeBool())
    if kind == 3:
        return fdp.ConsumeInt(fdp.ConsumeIntInRange(1, 8))
    if kind == 4:
        return fdp.PickValueInList([10 ** 400, -10 ** 400, 10 ** 5000, 2 ** 63, -2 ** 63 - 1, 0])
    if kind == 5:
        return fdp.ConsumeRegularFloat()
    if kind == 6:
        return fdp.PickValueInList([float("nan"), float("inf"), -float("inf"), -0.0, 5e-324,
                                    1.7976931348623157e308])
    if kind == 7:
        return fdp.PickValueInList(TEXTS)
    if kind == 8:
        return fdp.ConsumeUnicodeNoSurrogates(fdp.ConsumeIntInRange(0, 64))
    if kind == 9:
        return "x" * 1_000_000
    if kind == 10:
        return fdp.ConsumeBytes(fdp.ConsumeIntInRange(0, 16))
    if kind == 11:
        return pathlib.Path(fdp.PickValueInList(MODELS + TEXTS[:8]))
    if kind == 12:
        return fdp.PickValueInList(MODELS)
    if kind == 13 and depth < 3:
        return [value(fdp, depth + 1) for _ in range(fdp.ConsumeIntInRange(0, 4))]
    if kind == 14 and depth < 3:
        return tuple(value(fdp, depth + 1) for _ in range(fdp.ConsumeIntInRange(0, 4)))
    if kind == 15 and depth < 3:
        keys = [fdp.PickValueInList(["shaft", "x", "y", "shoulder", "elbow", "j1", ""]),
                fdp.ConsumeInt(2), None, ("a",), b"shaft"]
        return {fdp.PickValueInList(keys): value(fdp, depth + 1)
                for _ in range(fdp.ConsumeIntInRange(0, 3))}
    if kind == 16:
        return np.array([fdp.ConsumeRegularFloat() for _ in range(fdp.ConsumeIntInRange(0, 5))])
    if kind == 17:
        return np.broadcast_to(np.float64(fdp.ConsumeRegularFloat()), (10 ** 9,))
    if kind == 18:
        return np.float64(fdp.PickValueInList([float("nan"), 1.0, 1e300, -5.0]))
    if kind == 19:
        return fractions.Fraction(fdp.ConsumeInt(2), fdp.ConsumeIntInRange(1, 1000))
    if kind == 20:
        return decimal.Decimal(fdp.PickValueInList(["nan", "snan", "1e99999", "0.1", "-inf"]))
    if kind == 21:
        return complex(fdp.ConsumeRegularFloat(), 1)
    if kind == 22:
        return range(10 ** 9)
    if kind == 23:
        return (x for x in range(3))
    if kind == 24:
        loop = [1.0]
        loop.append(loop)
        return loop
    if kind == 25:
        return Raises(fdp.PickValueInList([ValueError("raised"), TypeError("raised"),
                                           RuntimeError("raised"), OverflowError("raised")]))
    if kind == 26:
        return np.zeros((2, 2))
    return object()


def message_ok(e):
    text = str(e)
    assert len(text) <= 2100, f"{type(e).__name__} of {len(text)} characters: {text[:200]!r}"
    assert not re.search(r"[\x00-\x09\x0b-\x1f\x7f]", text), f"control character in {text!r}"
    return text


def call(name, fdp):
    builder, positional = BUILDERS[name]
    args = []
    for p in positional:
        if p in ("model", "robot") and fdp.ConsumeIntInRange(0, 3):
            args.append(fdp.PickValueInList(MODELS))
        else:
            args.append(value(fdp))
    keywords = {}
    for _ in range(fdp.ConsumeIntInRange(0, 4)):
        key = (fdp.PickValueInList(KEYWORDS[name]) if KEYWORDS[name] and fdp.ConsumeIntInRange(0, 7)
               else fdp.PickValueInList(["bogus", "quite", "allow-coarse"]))
        keywords[key] = value(fdp)
    try:
        line = builder(*args, **keywords)
    except TypeError as e:
        text = message_ok(e)
        if text == "raised":  # the caller's own object's error, passed through
            return
        # Python's own "unexpected keyword argument" names it; ours name the argument.
        named = [p for p in positional + list(keywords) if p in text]
        assert named or "positional argument" in text, f"TypeError names no argument: {text!r}"
        return
    except (ValueError, FileNotFoundError) as e:
        message_ok(e)
        return
    assert isinstance(line, list) and all(isinstance(a, str) for a in line), line
    try:
        ex.check(line)
    except ValueError as e:
        text = message_ok(e)
        for option in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text):
            assert option not in OPTION_WORDS, f"the parser's {option} in a Python message: {text!r}"


def step_times(fdp):
    try:
        steps = mjstepper.StepTimes(value(fdp), value(fdp) if fdp.ConsumeBool() else None)
    except (TypeError, ValueError) as e:
        message_ok(e)
        return
    try:
        steps.count(value(fdp))
    except (TypeError, ValueError) as e:
        message_ok(e)


def TestOneInput(data):
    fdp = atheris.FuzzedDataProvider(data)
    which = fdp.ConsumeIntInRange(0, len(BUILDERS))
    try:
        if which == len(BUILDERS):
            step_times(fdp)
        else:
            call(list(BUILDERS)[which], fdp)
    except Exception as e:  # the caller's own objects' errors (Raises) pass through as they are
        if str(e) != "raised":
            raise
    assert not os.listdir("."), f"the working folder holds {os.listdir('.')}"


if __name__ == "__main__":
    atheris.Setup(sys.argv, TestOneInput)
    atheris.Fuzz()

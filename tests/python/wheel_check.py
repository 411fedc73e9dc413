"""Run inside a fresh virtual environment where only the mjstepper wheel (and what it requires) is
installed: import, signals by name, presets, the library's run-time needs, the version check, the
checks of every argument (issue 16), and the Ray sweep and map against the C++ ones."""
import math
import os
import stat
import subprocess
import sys
import tempfile
import unittest
from unittest import mock

import mujoco
import numpy as np

import mjstepper

SOURCE = sys.argv[1]
CPP_SWEEP = sys.argv[2]  # `mjstepper sweep` of the same grid, every digit
CPP_MAP = sys.argv[3]  # `mjstepper map` of the coupling model, every digit


class WheelInAFreshEnvironment(unittest.TestCase):
    def test_steps_a_model_and_reads_signals_by_name(self):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        self.assertEqual(mjstepper.add_signal_sensors(spec), ["shaft"])
        self.assertEqual(mjstepper.add_signal_sensors(spec), [])  # once only
        model = spec.compile()
        data = mujoco.MjData(model)
        omega = 100 * 2 * math.pi / 60  # rad/s
        for _ in range(4000):  # 0.2 s at 100 r/min (velocity input)
            data.ctrl[0] = omega
            mujoco.mj_step(model, data)
        signals = mjstepper.signals(model, data, "shaft")
        self.assertEqual(tuple(signals), mjstepper.SIGNALS)
        self.assertAlmostEqual(data.qpos[0] / (omega * 0.2), 1.0, delta=0.02)
        current_a, unit = signals["current_a"]
        self.assertEqual(unit, "A")
        magnitude = math.hypot(current_a, signals["current_b"][0])
        self.assertAlmostEqual(magnitude, 1.9, delta=0.19)  # the PI loop's 1.9 A (ripple, lag)
        self.assertEqual(signals["lost_steps"], (0.0, "full steps"))
        with self.assertRaises(KeyError):
            mjstepper.signals(model, data, "no_such_actuator")

    def test_config_edited_through_mjspec(self):
        """mjstepper.configure edits the spec's plugin config: the drive holds 1.5 A instead of
        the default 1.9 A, and a bad value fails to compile, naming it."""
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        mjstepper.configure(spec, "shaft", hold_current=1.5)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        self.assertAlmostEqual(mjstepper.signals(model, data, "shaft")["current_d"][0], 1.5,
                               delta=1e-12)
        mjstepper.configure(spec, "shaft", hold_current=-1)
        with self.assertRaises(ValueError) as ctx:
            spec.compile()
        self.assertIn('hold_current = "-1"', str(ctx.exception))

    def test_step_time_list_drives_a_stepping_stepper(self):
        """Issue 17: a motion controller's step times (mjstepper.StepTimes, the command line's
        steps(FILE) format) drive a chopper with input=steps; the drive's commanded angle is the
        list's count of microsteps; a bad list names its file and line."""
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        mjstepper.configure(spec, "shaft", drive="chopper", input="steps", bus_voltage=24,
                            run_current=1.3)
        model = spec.compile()
        data = mujoco.MjData(model)
        path = os.path.join(tempfile.mkdtemp(), "moves.txt")
        with open(path, "w") as f:
            f.write("# 400 microsteps forward at 8 kHz, 80 back\n")
            f.writelines(f"{k * 125e-6}\n" for k in range(1, 401))
            f.writelines(f"{0.05 + k * 125e-6} -1\n" for k in range(1, 81))
        steps = mjstepper.StepTimes.read(path)
        self.assertEqual(steps.count(0.05), 400)
        while data.time < steps.last_time + 0.005:
            data.ctrl[0] = steps.count(data.time + model.opt.timestep)
            mujoco.mj_step(model, data)
        step = 2 * math.pi / (4 * 50 * 16)  # rad per microstep
        self.assertAlmostEqual(mjstepper.signals(model, data, "shaft")["theta_cmd"][0],
                               320 * step, delta=1e-12)
        with open(path, "a") as f:
            f.write("0.01\n")
        with self.assertRaises(ValueError) as ctx:
            mjstepper.StepTimes.read(path)
        self.assertIn("moves.txt:482", str(ctx.exception))
        self.assertIn("must not decrease", str(ctx.exception))

    def test_presets_with_units(self):
        tsui = mjstepper.PRESETS["tsui2009"]
        self.assertEqual(tsui["rotor_inertia"], (0.36e-4, "kg·m²"))
        self.assertEqual(tsui["rated_current"], (3.0, "A"))
        self.assertEqual(set(mjstepper.PRESETS),
                         {"tsui2009", "kim2016", "bodson1993",  # the papers (SPEC §4)
                          "qsh4218_35", "qsh4218_41", "qsh4218_51", "qsh5718_51", "qsh5718_76",
                          "17hm19_2004s", "17hs19_2004s1"})  # catalogue motors (SPEC §8)
        # A catalogue motor's Km comes from its datasheet: T_H/(√2·I_r), QSH5718-76 1.89 N·m, 2.8 A.
        self.assertAlmostEqual(mjstepper.PRESETS["qsh5718_76"]["torque_constant"][0],
                               1.89 / (2 ** 0.5 * 2.8), places=12)

    def test_library_needs_only_mujoco_from_the_package(self):
        dynamic = subprocess.run(["readelf", "-d", mjstepper.LIBRARY], capture_output=True,
                                 text=True, check=True).stdout
        self.assertIn("[$ORIGIN/../mujoco]", dynamic)  # RUNPATH: the installed mujoco package
        needed = [line.split("[")[1].rstrip("]") for line in dynamic.splitlines()
                  if "(NEEDED)" in line]
        self.assertIn(f"libmujoco.so.{mujoco.__version__}", needed)
        for library in needed:  # C and C++ runtimes, and MuJoCo: no Debian library (libfmt)
            self.assertTrue(library.startswith(("libmujoco", "libstdc++", "libm.", "libgcc_s",
                                                "libc.")), library)

    def test_refuses_another_mujoco_naming_both_versions(self):
        code = "import mujoco; mujoco.__version__ = '3.9.9'; import mjstepper"
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        self.assertNotEqual(result.returncode, 0)
        self.assertIn("3.9.9", result.stderr)
        self.assertIn(mujoco.__version__, result.stderr)


class RaySweep(unittest.TestCase):
    def test_matches_the_cpp_sweep_on_a_local_ray(self):
        """mjstepper.sweep on a local Ray instance (2 CPUs) gives the C++ sweep's rows to
        1e-12 (relative, or absolute below 1), and writes them as CSV with the same header."""
        import csv
        import ray
        with open(CPP_SWEEP) as f:
            cpp = list(csv.reader(f))
        speeds = [float(row[1]) for row in cpp[1:]]  # rad/s, exactly the C++ grid
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            out = os.path.join(os.getcwd(), "ray_sweep.csv")
            rows = mjstepper.sweep(os.path.join(SOURCE, "models", "tsui_rigid.xml"), speeds,
                               settle=0.2, measure=0.2, out=out, progress=False)
        finally:
            ray.shutdown()
        self.assertEqual(len(rows), len(speeds))
        for row, expected in zip(rows, cpp[1:]):
            for got, want in zip(row, expected):
                self.assertLessEqual(abs(got - float(want)), 1e-12 * max(1.0, abs(float(want))))
        with open(out) as f:
            written = list(csv.reader(f))
        self.assertEqual(written[0], cpp[0])
        self.assertEqual(len(written), len(cpp))
        self.assertFalse(os.path.exists(out + ".tmp"))
        # Not a degenerate grid: the resonances ripple more than their neighbours.
        self.assertGreater(max(r[3] for r in rows), 2 * min(r[3] for r in rows))

    def test_map_matches_the_cpp_map_on_a_local_ray(self):
        """mjstepper.resonance_map on a local Ray gives `mjstepper map`'s rows to 1e-12."""
        import csv
        import ray
        with open(CPP_MAP) as f:
            cpp = list(csv.reader(f))
        values = sorted({float(row[0]) for row in cpp[1:]})
        speeds = sorted({float(row[2]) for row in cpp[1:]})
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            rows = mjstepper.resonance_map(os.path.join(SOURCE, "models", "tsui_coupling.xml"),
                                           speeds, "stiffness:coupling", values, settle=0.2,
                                           measure=0.2, progress=False)
        finally:
            ray.shutdown()
        self.assertEqual(len(rows), len(cpp) - 1)
        for row, expected in zip(rows, cpp[1:]):
            for got, want in zip(row, expected):
                self.assertLessEqual(abs(got - float(want)), 1e-12 * max(1.0, abs(float(want))))


class HostileArguments(unittest.TestCase):
    """Issue 16: every argument of the package's functions is checked where it is given, and the
    error names it (and its range), instead of failing later or elsewhere."""

    def compiled(self, plain=False):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        if plain:  # a second actuator, not a stepper
            spec.add_actuator(name="plain", target="shaft", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        return model, data

    def test_signals_takes_any_integer_id_but_a_bool(self):
        model, data = self.compiled()
        by_name = mjstepper.signals(model, data, "shaft")
        for actuator in (0, np.int64(0), np.int32(0), np.uint8(0)):
            self.assertEqual(mjstepper.signals(model, data, actuator), by_name, repr(actuator))
        for actuator in (True, np.bool_(False), 0.0, None, b"shaft"):
            with self.assertRaises(TypeError) as ctx:
                mjstepper.signals(model, data, actuator)
            self.assertIn("actuator", str(ctx.exception))

    def test_signals_names_an_id_out_of_range_and_a_non_stepper(self):
        model, data = self.compiled(plain=True)
        for actuator in (99, np.int64(2), -1):
            with self.assertRaises(IndexError) as ctx:
                mjstepper.signals(model, data, actuator)
            message = str(ctx.exception)
            self.assertIn(f"no actuator {int(actuator)}", message)
            self.assertIn("[0, model.nu) = [0, 2)", message)
            self.assertNotIn("sensor", message)
        for actuator in ("plain", 1):
            with self.assertRaises(ValueError) as ctx:
                mjstepper.signals(model, data, actuator)
            self.assertIn("'plain' (id 1) is not an mjstepper stepper", str(ctx.exception))
        self.assertEqual(tuple(mjstepper.signals(model, data, 0)), mjstepper.SIGNALS)

    def test_configure_rejects_an_unknown_attribute_at_once(self):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        before = dict(spec.actuators[0].plugin.config)
        with self.assertRaises(ValueError) as ctx:
            mjstepper.configure(spec, "shaft", hold_current=1.5, hold_curent=1)
        self.assertIn("'hold_curent'", str(ctx.exception))
        self.assertIn("did you mean hold_current", str(ctx.exception))
        self.assertEqual(dict(spec.actuators[0].plugin.config), before)  # nothing set
        for attribute, value in (("hold_current", None), ("hold_current", True),
                                 ("microsteps", 2.5), ("detent", [])):
            with self.assertRaises(TypeError) as ctx:
                mjstepper.configure(spec, "shaft", **{attribute: value})
            self.assertIn(f"{attribute} = {value!r}", str(ctx.exception))
        self.assertEqual(dict(spec.actuators[0].plugin.config), before)
        mjstepper.configure(spec, "shaft", hold_current=np.float64(1.5), microsteps=np.int64(16),
                            gauge=False, detent="none")
        self.assertEqual({k: v for k, v in spec.actuators[0].plugin.config.items()
                          if k not in before},
                         {"hold_current": "1.5", "microsteps": "16", "gauge": "off",
                          "detent": "none"})
        spec.compile()

    def test_attribute_names_are_the_plugins_table(self):
        """mjstepper.ATTRIBUTES (generated from the C++ table) lists plugin/README.md's table,
        which is generated from the same table (and checked by a C++ test)."""
        with open(os.path.join(SOURCE, "plugin", "README.md"), encoding="utf-8") as f:
            lines = f.read().split("| Attribute | Type |", 1)[1].splitlines()[2:]
        documented = []
        for line in lines:
            if not line.startswith("| `"):
                break
            documented.append(line.split("`")[1])
        self.assertEqual(mjstepper.ATTRIBUTES, tuple(documented))
        self.assertEqual(mjstepper.ATTRIBUTE_UNITS["hold_current"], "A")


class SweepArguments(unittest.TestCase):
    """sweep and resonance_map check every argument before any work, without Ray; no run starts."""
    MODEL = os.path.join(SOURCE, "models", "tsui_rigid.xml")
    COUPLING = os.path.join(SOURCE, "models", "tsui_coupling.xml")

    def assertRejects(self, error, words, function=None, **arguments):
        arguments.setdefault("speeds", [5.0])
        with mock.patch.dict(sys.modules, {"ray": None}):  # a run would need Ray: none starts
            with self.assertRaises(error) as ctx:
                (function or mjstepper.sweep)(arguments.pop("model", self.MODEL), **arguments)
        for word in words:
            self.assertIn(word, str(ctx.exception))

    def test_every_numeric_argument_names_itself_and_its_range(self):
        missing = "/no/such/model.xml"  # checked before the model is read
        self.assertRejects(ValueError, ["settle = -1", "[0, 60] s"], settle=-1, model=missing)
        self.assertRejects(ValueError, ["settle = nan", "[0, 60] s"], settle=math.nan)
        self.assertRejects(ValueError, ["measure = 0.0 s", "[0.01, 60] s"], measure=0, model=missing)
        self.assertRejects(ValueError, ["measure = 61", "[0.01, 60] s"], measure=61)
        self.assertRejects(TypeError, ["measure = '0.5'"], measure="0.5")
        self.assertRejects(ValueError, ["acceleration = 0", "> 0"], acceleration=0)
        self.assertRejects(ValueError, ["speeds = []", "at least one"], speeds=[], model=missing)
        self.assertRejects(ValueError, ["speeds[1] = 20000", "0 < |speed| <= 10000 rad/s"],
                           speeds=[5.0, 2e4])
        self.assertRejects(ValueError, ["speeds[0] = 0.0 rad/s"], speeds=np.zeros(3))
        self.assertRejects(ValueError, ["speeds[0] = inf"], speeds=[math.inf])
        self.assertRejects(ValueError, ["100001 speeds", "at most 100000"],
                           speeds=np.ones(100_001))
        self.assertRejects(TypeError, ["speeds[0] = True"], speeds=[True])
        self.assertRejects(TypeError, ["speeds = 5.0"], speeds=5.0)
        self.assertEqual((mjstepper._sweep.SETTLE_RANGE, mjstepper._sweep.MEASURE_RANGE,
                          mjstepper._sweep.MAX_SPEED, mjstepper._sweep.MAX_SPEEDS),
                         ((0, 60), (0.01, 60), 1e4, 100_000))

    def test_map_values_name_the_parameters_range(self):
        resonance_map = mjstepper.resonance_map
        stiffness = {"function": resonance_map, "model": self.COUPLING,
                     "parameter": "stiffness:coupling"}
        mass = {"function": resonance_map, "model": self.COUPLING, "parameter": "mass:load"}
        self.assertRejects(ValueError, ["values[0] = -100.0 N·m/rad", "0 < value <= 1e+12 N·m/rad or N/m"],
                           values=[-100], **stiffness)
        self.assertRejects(ValueError, ["values[1] = 2000000000000.0"], values=[20, 2e12], **stiffness)
        self.assertRejects(ValueError, ["values = []", "at least one"], values=[], **stiffness)
        self.assertRejects(ValueError, ["values[0] = 0.0 kg", "0 < value <= 1e+06 kg"], values=[0],
                           **mass)
        self.assertRejects(ValueError, ["values[0] = nan", "kg"], values=[math.nan], **mass)
        self.assertRejects(ValueError, ["values[0] = 2000000.0", "kg"], values=[2e6], **mass)
        self.assertRejects(ValueError, ["parameter = 'damping:coupling'"], values=[1],
                           function=resonance_map, parameter="damping:coupling")
        self.assertRejects(ValueError, ["no joint named 'nothing'"], values=[1],
                           function=resonance_map, model=self.COUPLING,
                           parameter="stiffness:nothing")

    def test_measure_holds_at_least_100_timesteps(self):
        with open(self.MODEL) as f:
            coarse = f.read().replace('timestep="5e-5"', 'timestep="2e-4"')
        path = os.path.join(os.getcwd(), "tsui_coarse.xml")
        with open(path, "w") as f:
            f.write(coarse)
        self.assertRejects(ValueError, ["measure = 0.01 s", "50 timesteps", "at least 100",
                                        "measure >= 0.02 s"], model=path, measure=0.01)
        self.assertRejects(ModuleNotFoundError, ["mjstepper[ray]"], model=path, measure=0.02)

    def test_out_replaces_only_a_regular_file(self):
        # A symbolic link, a FIFO or a directory as `out` is refused before any run (a CSV would
        # have replaced it), and left as it was; a regular file is written whole, nothing beside it.
        folder = tempfile.mkdtemp()
        target = os.path.join(folder, "target.csv")
        with open(target, "w") as f:
            f.write("precious\n")
        link, fifo = os.path.join(folder, "link.csv"), os.path.join(folder, "fifo.csv")
        os.symlink(target, link)
        os.mkfifo(fifo)
        for out in (link, fifo, folder):
            self.assertRejects(OSError, [repr(out), "not a regular file"], out=out)
        self.assertTrue(os.path.islink(link) and stat.S_ISFIFO(os.lstat(fifo).st_mode))
        with open(target) as f:
            self.assertEqual(f.read(), "precious\n")
        mjstepper._sweep._write_csv(target, ("a", "b"), [(1, 2)])
        with open(target) as f:
            self.assertEqual(f.read().splitlines(), ["a,b", "1.0,2.0"])
        self.assertEqual(sorted(os.listdir(folder)), ["fifo.csv", "link.csv", "target.csv"])

    def test_the_stepper_is_checked_on_the_driver(self):
        self.assertRejects(KeyError, ["no actuator named 'nothing'"], actuator="nothing")
        self.assertRejects(IndexError, ["no actuator 3"], actuator=3)

    def test_without_ray_says_how_to_install_it(self):
        self.assertRejects(ModuleNotFoundError, ['pip install "mjstepper[ray]"', "mjstepper.sweep"],
                           measure=0.01)
        self.assertRejects(ModuleNotFoundError, ['pip install "mjstepper[ray]"',
                                                 "mjstepper.resonance_map"],
                           function=mjstepper.resonance_map, model=os.path.join(
                               SOURCE, "models", "tsui_coupling.xml"),
                           parameter="mass:load", values=[0.5])


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)

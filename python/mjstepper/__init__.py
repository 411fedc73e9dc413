"""mjstepper: stepper motors and their drives as a MuJoCo actuator plugin.

`import mjstepper` loads the plugin library into the installed mujoco (which must be the version it
was built against), after which MJCF models may use `mjstepper.stepper` actuators and sensors.

    import mujoco, mjstepper
    spec = mujoco.MjSpec.from_file("models/tsui_rigid.xml")
    mjstepper.add_signal_sensors(spec)
    model = spec.compile(); data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    mjstepper.signals(model, data, "shaft")["current_a"]   # (value, "A")
"""
import os

import mujoco

from . import _tables

if mujoco.__version__ != _tables.MUJOCO_VERSION:
    raise ImportError(
        f"mjstepper was built for MuJoCo {_tables.MUJOCO_VERSION} but the installed mujoco is "
        f"{mujoco.__version__}: install mujoco=={_tables.MUJOCO_VERSION}, or rebuild mjstepper "
        f"against this mujoco (pip install --force-reinstall --no-cache-dir <mjstepper source>)")

PLUGIN_NAME = "mjstepper.stepper"
LIBRARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "libmjstepper.so")
mujoco.mj_loadPluginLibrary(LIBRARY)

#: Signal names, in sensordata order, and their units (from the C++ signal table).
SIGNALS = tuple(name for name, _, _ in _tables.SIGNALS)
UNITS = {name: unit for name, unit, _ in _tables.SIGNALS}
MEANINGS = {name: meaning for name, _, meaning in _tables.SIGNALS}
#: Every preset's parameters as {name: (value, unit)}.
PRESETS = _tables.PRESETS


def signals(model, data, actuator):
    """{name: (value, unit)} of the stepper on `actuator` (name or id), from its signal sensor
    (mjstepper.add_signal_sensors adds one to every stepper)."""
    actuator_id = actuator if isinstance(actuator, int) else mujoco.mj_name2id(
        model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator)
    if actuator_id < 0:
        raise KeyError(f"no actuator named {actuator!r}")
    for s in range(model.nsensor):
        if (model.sensor_type[s] == mujoco.mjtSensor.mjSENS_PLUGIN
                and model.sensor_objtype[s] == mujoco.mjtObj.mjOBJ_ACTUATOR
                and model.sensor_objid[s] == actuator_id):
            adr = model.sensor_adr[s]
            values = data.sensordata[adr:adr + len(SIGNALS)]
            return {name: (float(v), UNITS[name]) for name, v in zip(SIGNALS, values)}
    raise KeyError(f"actuator {actuator!r} has no mjstepper signal sensor; "
                   "call mjstepper.add_signal_sensors(spec) before compiling")


def configure(spec, actuator, **attributes):
    """Sets plugin attributes (plugin/README.md) of the stepper on `actuator` in an MjSpec, through
    the spec's own plugin config, e.g. configure(spec, "shaft", drive="servo", hold_current=1.5).
    An actuator on a named instance changes the instance (and every actuator sharing it)."""
    a = next((x for x in spec.actuators if x.name == actuator), None)
    if a is None or not a.plugin.active:
        raise KeyError(f"no mjstepper actuator named {actuator!r}")
    target = a.plugin
    if not a.plugin.plugin_name:  # on a named instance
        target = next(p for p in spec.plugins if p.name == a.plugin.name)
    target.config = {**target.config, **{k: str(v) for k, v in attributes.items()}}


def add_signal_sensors(spec):
    """Adds a signal sensor to every mjstepper actuator of an MjSpec that has none; returns the
    names of the actuators that got one."""
    covered = {s.objname for s in spec.sensors
               if s.type == mujoco.mjtSensor.mjSENS_PLUGIN
               and s.objtype == mujoco.mjtObj.mjOBJ_ACTUATOR}
    added = []
    for a in spec.actuators:
        if not a.plugin.active or a.name in covered:
            continue
        plugin_name = a.plugin.plugin_name
        if not plugin_name:  # an actuator on a named instance: the instance names the plugin
            instance = next((p for p in spec.plugins if p.name == a.plugin.name), None)
            plugin_name = instance.plugin_name if instance is not None else ""
        if plugin_name != PLUGIN_NAME:
            continue
        if not a.name:
            raise ValueError("a stepper actuator has no name; name it to read its signals")
        probe = spec.add_plugin(plugin_name=PLUGIN_NAME, active=True)
        sensor = spec.add_sensor(name=f"mjstepper:{a.name}", type=mujoco.mjtSensor.mjSENS_PLUGIN,
                                 objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname=a.name)
        sensor.plugin = probe
        added.append(a.name)
    return added


from ._sweep import resonance_map, sweep  # noqa: E402,F401  (Ray is imported only when run)

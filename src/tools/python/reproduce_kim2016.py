#!/usr/bin/env python3
"""Regenerates docs/reproduction/kim2016.md and its figures in renders/kim2016/.

Runs build/mjstepper on models/kim_stmms.xml, models/kim_foc_case1.xml and models/kim_foc_case2.xml
under three conditions (the ideal 1 MHz drive, the bench's 5 kHz sampling, Tsui's detent harmonics
added to the motor), two runs at a time, measures the tracking metrics, compares the ripple with
Kim's eq. (35) and with the linearised loop, draws the paper's Figs. 5-7, and writes the report with
the numbers it measured. Run through scripts/reproduce_kim2016.sh, which builds first.
"""
import concurrent.futures
import math
import os
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mjstepper_plot import column, read_csv  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")
LOGS = os.path.join(ROOT, "logs", "reproduction")
FIGS = os.path.join(ROOT, "renders", "kim2016")
REPORT = os.path.join(ROOT, "docs", "reproduction", "kim2016.md")
SEED = "/work/shared/seeds/001_e3b5bc750dcb039e.txt"

DURATION = 4.0
TARGET = "constant(15.70796327rad)"          # 5π: the drive's trapezoid profile makes Kim's θd
MOTION = (0.5, 3.5)                          # θd moves between these times
TRANSIENT = [(0.5, 1.0), (3.0, 3.5)]         # acceleration and deceleration
CRUISE = (1.5, 2.5)                          # inside the 1.0-3.0 s cruise, transients gone; 1 s
REST = (3.5, DURATION)                       # θd at rest
DETENT = "4 0.006 0; 2 0.014 3.1416; 1 0.011 1.5708"   # Tsui 2009's harmonics (SPEC §4)
BENCH_PERIOD = 2e-4                          # Kim's bench: 5 kHz control

# Kim §5's gain sets (SPEC §3, §7): inputs of the study, the drives' defaults.
CONTROLLERS = {
    "STMMS": dict(model="models/kim_stmms.xml", kind="stmms", k1p=40000.0, rho=None, colour="C0"),
    "FOC case 1": dict(model="models/kim_foc_case1.xml", kind="foc", k1p=1000.0, rho=25000.0,
                       colour="C3"),
    "FOC case 2": dict(model="models/kim_foc_case2.xml", kind="foc", k1p=10000.0, rho=10000.0,
                       colour="C2"),
}
K0, K1, K2 = 10.0, 20.0, 100.0
H18 = {"STMMS": 7.58e-8, "FOC case 1": 2.894e-6, "FOC case 2": 3.03e-7}   # SPEC §5, rad/(N·m)
CONDITIONS = {
    "a": ("(a) ideal drive, 1 MHz", []),
    "b": ("(b) 5 kHz control", [f"shaft.isr_period={BENCH_PERIOD:g}"]),
    "c": ("(c) 1 MHz + detent", [f"shaft.detent={DETENT}"]),
}
# One more run: FOC case 2 at 5 kHz with the backward-difference reference derivative, to see
# whether its instability comes from the analytic derivative (it is not one of the nine).
EXTRA = ("b-num", "FOC case 2", "(b) 5 kHz, numeric i̇d",
         [f"shaft.isr_period={BENCH_PERIOD:g}", "shaft.foc_derivative=numeric"])
SIGNALS = ["theta", "theta_cmd", "omega", "load_angle", "current_a", "current_b", "current_ref_a",
           "current_ref_b", "voltage_a", "voltage_b", "torque_detent", "lost_steps"]
HUGE = 1e6


# --- running ----------------------------------------------------------------------------------------

def cli(*args, tries=10):
    """Runs build/mjstepper; waits out a rebuild that briefly removes the binary. (rc, output)."""
    for attempt in range(tries):
        if not os.path.exists(CLI):
            time.sleep(30)
            continue
        try:
            r = subprocess.run([CLI, *args], capture_output=True, text=True, cwd=ROOT)
        except OSError:                       # binary being rewritten (ETXTBSY, ENOENT)
            time.sleep(30)
            continue
        if r.returncode != 0 and not os.path.exists(CLI) and attempt + 1 < tries:
            time.sleep(30)
            continue
        return r.returncode, r.stdout + r.stderr
    sys.exit(f"{CLI} missing for {tries} tries")


def simulate(job):
    """One run (in a worker process): the CLI, then the columns the study needs as arrays."""
    key, name, sets = job
    path = os.path.join(LOGS, f"kim2016_{key}.csv")
    args = ["run", CONTROLLERS[name]["model"], "--duration", str(DURATION), "--ctrl",
            f"shaft={TARGET}", "--log", path, "--quiet"]
    for s in sets:
        args += ["--set", s]
    if os.path.exists(path):
        os.remove(path)
    start = time.time()
    rc, out = cli(*args)
    result = {"key": key, "name": name, "rc": rc, "output": out, "wall": time.time() - start,
              "args": args}
    if not os.path.exists(path):
        return result
    _, c = read_csv(path)
    result["t"] = np.array(c["time[s]"])
    for s in SIGNALS:
        result[s] = np.array(column(c, "shaft", s)[0])
    return result


# --- model parameters -------------------------------------------------------------------------------

def parameters():
    """Motor values from `mjstepper info` (the preset as loaded), J, B, τl, Vbus from the MJCF."""
    rc, out = cli("info", CONTROLLERS["STMMS"]["model"])
    if rc != 0:
        sys.exit(f"mjstepper info failed:\n{out}")
    m = re.search(r"Nr (\d+), R ([\d.e+-]+) Ω, L ([\d.e+-]+) H, Km ([\d.e+-]+) N·m/A", out)
    if not m:
        sys.exit(f"cannot read the motor line of mjstepper info:\n{out}")
    p = dict(Nr=int(m.group(1)), R=float(m.group(2)), L=float(m.group(3)), Km=float(m.group(4)))
    tree = ET.parse(os.path.join(ROOT, CONTROLLERS["STMMS"]["model"]))
    act = tree.find(".//actuator/plugin[@name='shaft']")
    cfg = {c.get("key"): c.get("value") for c in act.findall("config")}
    load = tree.find(".//actuator/general[@name='load']")
    p.update(J=float(act.get("armature")), B=float(act.get("damping")),
             tl=-float(load.get("biasprm").split()[0]), Vbus=float(cfg["bus_voltage"]),
             isr=float(cfg["isr_period"]), speed=float(cfg["profile_speed"]),
             accel=float(cfg["profile_accel"]), timestep=float(tree.find("option").get("timestep")))
    p["info"] = out.strip()
    return p


# --- metrics ----------------------------------------------------------------------------------------

def window(t, span):
    return (t >= span[0] - 1e-9) & (t < span[1] - 1e-9)


def metrics(r, p):
    m = {"rc": r["rc"]}
    if "t" not in r:
        m["verdict"] = f"run failed (exit {r['rc']}), no log"
        return m
    t = r["t"]
    values = np.stack([r[s] for s in SIGNALS])
    finite = np.isfinite(values).all(axis=0) & (np.abs(values) < HUGE).all(axis=0)
    reset = bool((np.diff(t) <= 0).any())
    # θ − θd from the load angle: δ = Nr·(θcmd − θ) is formed in double precision before printing,
    # so its 10 significant digits resolve e1 far below the 1e-8 rad of the printed θ and θd.
    e1 = -r["load_angle"] / p["Nr"]
    raw = r["theta"] - r["theta_cmd"]
    m["print_gap"] = float(np.nanmax(np.abs(raw - e1)))
    m["print_quantum"] = 0.5 * 10.0 ** (math.floor(math.log10(np.nanmax(np.abs(r["theta"])))) - 9)
    v = np.maximum(np.abs(r["voltage_a"]), np.abs(r["voltage_b"]))
    di2 = (r["current_a"] - r["current_ref_a"]) ** 2 + (r["current_b"] - r["current_ref_b"]) ** 2
    mo, cr, re_ = window(t, MOTION), window(t, CRUISE), window(t, REST)
    tr = np.zeros_like(mo)
    for span in TRANSIENT:
        tr |= window(t, span)
    m.update(
        t_end=float(t[-1]),
        e1_motion=float(np.max(np.abs(e1[mo]))),
        e1_transient=float(np.max(np.abs(e1[tr]))),
        e1_cruise_mean=float(np.mean(e1[cr])),
        e1_cruise_pp=float(np.ptp(e1[cr])),
        e1_end=float(abs(e1[-1])),
        e1_rest_pp=float(np.ptp(e1[window(t, (3.75, DURATION))])),
        v_peak=float(np.max(v)),
        i_rms=float(np.sqrt(np.mean(di2[mo]))),
        bus_fraction=float(np.mean(v[t >= MOTION[0]] >= p["Vbus"] * (1 - 1e-6))),
        bus_fraction_rest=float(np.mean(v[re_] >= p["Vbus"] * (1 - 1e-6))),
        lost_max=float(np.max(np.abs(r["lost_steps"]))),
        lost_end=float(r["lost_steps"][-1]),
        omega_rest=float(np.max(np.abs(r["omega"][re_]))),
        nonfinite=int(np.sum(~finite)), reset=reset)
    # Dominant frequency of va while θd is at rest: the frequency of a limit cycle, if any.
    x = r["voltage_a"][re_] - np.mean(r["voltage_a"][re_])
    spectrum = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    freqs = np.fft.rfftfreq(len(x), np.median(np.diff(t)))
    m["rest_frequency"] = float(freqs[1 + np.argmax(spectrum[1:])])
    if m["nonfinite"] or reset:
        m["verdict"] = "unstable: non-finite or huge values" + (" / reset" if reset else "")
    elif m["bus_fraction_rest"] > 0.01:
        m["verdict"] = (f"unstable: limit cycle at the {p['Vbus']:g} V bus, "
                        f"{m['rest_frequency']:.0f} Hz")
    elif m["bus_fraction"] > 0:
        m["verdict"] = "settles (touched the bus)"
    else:
        m["verdict"] = "stable, no saturation"
    m["unstable"] = m["verdict"].startswith("unstable") or m["verdict"].startswith("run failed")
    return m


def harmonics(r, p, orders=(1, 2, 4)):
    """Amplitudes of e1 and of the detent torque at h·Nr·ω/2π over the cruise window (1 s, whole
    cycles), and their ratio times J: the measured J·|E1/T̃|."""
    t = r["t"]
    cr = window(t, CRUISE)
    e1 = -r["load_angle"][cr] / p["Nr"]
    tau = r["torque_detent"][cr]
    n = len(e1)
    f = np.fft.rfftfreq(n, np.median(np.diff(t)))
    E = np.abs(np.fft.rfft(e1 - e1.mean())) * 2 / n
    D = np.abs(np.fft.rfft(tau - tau.mean())) * 2 / n
    out = {}
    for h in orders:
        hz = h * p["Nr"] * p["speed"] / (2 * math.pi)
        i = int(np.argmin(np.abs(f - hz)))
        out[h] = dict(hz=float(f[i]), e1=float(E[i]), tau=float(D[i]), ratio=float(p["J"] * E[i] / D[i]))
    return out


# --- linear analysis --------------------------------------------------------------------------------

def k35(freq, k1p):
    """J·|E1/T̃| of K(35) at freq (Hz): the reduced-order model, torque τ̄ = τd exactly."""
    s = 2j * math.pi * np.asarray(freq, dtype=float)
    return np.abs(s / (s ** 3 + (k1p + K2) * s ** 2 + (K1 + k1p * K2) * s + K0))


def rotor_frame(z, d, c, p, omega0):
    """dz/dt of the continuous closed loop in the rotor frame (S-11), z = (e0, e1, ω − ω0, id, iq),
    θd at constant speed omega0, d a disturbance torque; the controller of K(32) or K(34) with the
    analytic i̇d the `foc` drive uses by default."""
    e0, e1, w, i_d, i_q = z
    om = omega0 + w
    J, B, tl, Km, R, L, Nr = p["J"], p["B"], p["tl"], p["Km"], p["R"], p["L"], p["Nr"]
    k1p = c["k1p"]
    td = B * om + tl + J * (-k1p * w - K0 * e0 - K1 * e1 - K2 * (w + k1p * e1))
    iqd = td / Km
    if c["kind"] == "stmms":
        vd, vq = 0.0, R * iqd + Km * om                                   # K(28) in the rotor frame
    else:
        wm = (Km * i_q - B * om - tl) / J                                 # the drive's ω̇ model
        tdd = B * wm + J * (-k1p * wm - K0 * e1 - K1 * w - K2 * (wm + k1p * w))
        vd = R * i_d + L * (-Nr * om * iqd - c["rho"] * i_d)              # K(33) in the rotor frame
        vq = R * i_q + Km * om + L * (tdd / Km + c["rho"] * (iqd - i_q))
    return np.array([e1, w, (Km * i_q - B * om - tl + d) / J,
                     (vd - R * i_d + Nr * L * om * i_q) / L,
                     (vq - R * i_q - Nr * L * om * i_d - Km * om) / L])


def linearised(c, p, omega0):
    """(A, b) of the continuous loop linearised about steady motion at omega0 (id, iq at their
    steady values; the loop is linear in e0, e1)."""
    a = p["Nr"] * p["L"] * omega0 / p["R"]
    iq0 = (p["tl"] + p["B"] * omega0) / p["Km"]
    z0 = np.array([0.0, 0.0, 0.0, a * iq0 if c["kind"] == "stmms" else 0.0, iq0])
    A = np.zeros((5, 5))
    for j in range(5):
        dz = np.zeros(5)
        dz[j] = 1e-7 * max(1.0, abs(z0[j]))
        A[:, j] = (rotor_frame(z0 + dz, 0, c, p, omega0) - rotor_frame(z0 - dz, 0, c, p, omega0)) / (2 * dz[j])
    b = (rotor_frame(z0, 1e-3, c, p, omega0) - rotor_frame(z0, 0, c, p, omega0)) / 1e-3
    return A, b


def full_sensitivity(c, p, omega0, freqs):
    """J·|E1/T̃| of the linearised loop with the electrical dynamics (what K(35) leaves out)."""
    A, b = linearised(c, p, omega0)
    return np.array([p["J"] * abs(np.linalg.solve(2j * math.pi * f * np.eye(5) - A, b)[1]) for f in freqs])


def expm(M):
    """Matrix exponential: scaling and squaring with a Taylor series (small, well-scaled M)."""
    norm = np.linalg.norm(M, 1)
    s = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0 else 0
    A = M / 2 ** s
    E, term = np.eye(len(M)), np.eye(len(M))
    for k in range(1, 30):
        term = term @ A / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


def sampled_loop(c, p, period, numeric=False, inertia_ratio=1.0):
    """Spectral radius and oscillation frequency of the sampled loop at rest (q axis: e1, ω, iq, and
    e0 as the drive sums it, e0[k] = e0[k−1] + T·e1[k]; the voltage held over each period, no
    computation delay), the controller's J = inertia_ratio × the plant's."""
    J, B, Km, R, L = p["J"], p["B"], p["Km"], p["R"], p["L"]
    Jc = inertia_ratio * J
    Ac = np.array([[0, 1, 0], [0, -B / J, Km / J], [0, -Km / L, -R / L]])
    M = np.zeros((4, 4))
    M[:3, :3], M[:3, 3] = Ac, [0, 0, 1 / L]
    E = expm(M * period)
    Phi, Gam = E[:3, :3], E[:3, 3]
    n = 5 if numeric else 4                   # state (e1, ω, iq, e0[k−1] [, iqd[k−1]])
    S = np.zeros((4, n))                      # state → (e1, ω, iq, e0[k])
    S[:3, :3] = np.eye(3)
    S[3, 3], S[3, 0] = 1.0, period
    k1p = c["k1p"]
    tau = np.array([-Jc * (K1 + K2 * k1p), B - Jc * (k1p + K2), 0.0, -Jc * K0]) @ S
    iqd = tau / Km
    unit_iq = np.zeros(n)
    unit_iq[2] = 1.0
    emf = np.zeros(n)
    emf[1] = Km
    if c["kind"] == "stmms":
        v = R * iqd + emf
    elif numeric:
        previous = np.zeros(n)
        previous[4] = 1.0
        v = R * unit_iq + emf + L * ((iqd - previous) / period + c["rho"] * (iqd - unit_iq))
    else:
        wm = np.array([0.0, -B / Jc, Km / Jc, 0.0]) @ S
        tdd = B * wm - Jc * (k1p + K2) * wm - Jc * (np.array([K0, K1 + K2 * k1p, 0.0, 0.0]) @ S)
        v = R * unit_iq + emf + L * (tdd / Km + c["rho"] * (iqd - unit_iq))
    A = np.zeros((n, n))
    A[:3, :3] = Phi
    A[:3, :] += np.outer(Gam, v)
    A[3, :] = S[3, :]
    if numeric:
        A[4, :] = iqd
    ev = np.linalg.eigvals(A)
    i = int(np.argmax(np.abs(ev)))
    return float(abs(ev[i])), float(abs(np.angle(ev[i])) / (2 * math.pi * period))


def bisect(stable, lo, hi, log=True):
    """Boundary of `stable` between lo (stable) and hi (unstable)."""
    for _ in range(60):
        mid = math.sqrt(lo * hi) if log else 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def stability_table(p):
    rows = {}
    for name, c in CONTROLLERS.items():
        row = {}
        for label, period in [("ideal", p["isr"]), ("bench", BENCH_PERIOD)]:
            row[label] = sampled_loop(c, p, period)
        if row["ideal"][0] < 1:
            hi = BENCH_PERIOD if row["bench"][0] >= 1 else 1e-2
            row["max_period"] = bisect(lambda T: sampled_loop(c, p, T)[0] < 1, p["isr"], hi)
        else:
            row["max_period"] = float("nan")
        if row["bench"][0] >= 1:
            row["max_ratio"] = bisect(lambda a: sampled_loop(c, p, BENCH_PERIOD, inertia_ratio=a)[0] < 1,
                                      1e-6, 1.0)
        else:
            row["max_ratio"] = float("nan")
        if c["kind"] == "foc":
            row["bench_numeric"] = sampled_loop(c, p, BENCH_PERIOD, numeric=True)
        rows[name] = row
    return rows


# --- figures ----------------------------------------------------------------------------------------

def save(fig, name):
    path = os.path.join(FIGS, name)
    fig.tight_layout()
    fig.savefig(path + ".tmp.png", dpi=100)
    plt.close(fig)
    os.replace(path + ".tmp.png", path)
    return os.path.relpath(path, os.path.dirname(REPORT))


def error_figure(runs, p, title, name):
    """Kim Fig. 5: θd, then θd − θ (= −e1, Kim's sign) of each controller, then all three on a log
    scale."""
    names = list(CONTROLLERS)
    fig, ax = plt.subplots(len(names) + 2, 1, figsize=(8, 9.5), sharex=True)
    first = runs[names[0]]
    ax[0].plot(first["t"], first["theta_cmd"], lw=1, color="k")
    ax[0].set_ylabel("θd (rad)")
    for a, n in zip(ax[1:], names):
        r = runs[n]
        a.plot(r["t"], r["load_angle"] / p["Nr"], lw=0.6, color=CONTROLLERS[n]["colour"])
        a.set_ylabel("θd − θ (rad)")
        a.set_title(n, fontsize=9, loc="left")
        a.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    for n in names:
        r = runs[n]
        ax[-1].semilogy(r["t"], np.maximum(np.abs(r["load_angle"] / p["Nr"]), 1e-13), lw=0.6,
                        color=CONTROLLERS[n]["colour"], label=n)
    ax[-1].set_ylim(1e-12, None)
    ax[-1].set_ylabel("|θd − θ| (rad)")
    ax[-1].legend(fontsize=8, loc="lower center", ncol=3)
    ax[-1].set_xlabel("time (s)")
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle(title)
    return save(fig, name)


def phase_figure(runs, kind, title, name, zoom=(0.95, 1.05)):
    """Kim Fig. 6 (kind 'voltage': va, vb) or Fig. 7 (kind 'current': ia against iad), whole run on
    the left, a zoom across the end of the acceleration on the right."""
    names = list(CONTROLLERS)
    fig, ax = plt.subplots(len(names), 2, figsize=(10, 7.5), sharex="col",
                           gridspec_kw={"width_ratios": [2, 1]})
    for row, n in enumerate(names):
        r = runs[n]
        t = r["t"]
        z = window(t, zoom)
        for col, m in enumerate([np.ones_like(z), z]):
            a = ax[row, col]
            if kind == "voltage":
                a.plot(t[m], r["voltage_a"][m], lw=0.5, label="va")
                a.plot(t[m], r["voltage_b"][m], lw=0.5, label="vb")
                a.set_ylabel("voltage (V)")
            else:
                a.plot(t[m], r["current_ref_a"][m], lw=1.2, color="k", ls="--", label="iad")
                a.plot(t[m], r["current_a"][m], lw=0.6, color=CONTROLLERS[n]["colour"], label="ia")
                a.set_ylabel("phase A current (A)")
            a.grid(alpha=0.3)
        ax[row, 0].set_title(n, fontsize=9, loc="left")
        ax[row, 1].set_title(f"zoom {zoom[0]:g}-{zoom[1]:g} s", fontsize=9, loc="left")
        ax[row, 1].legend(fontsize=7, loc="upper right")
    ax[-1, 0].set_xlabel("time (s)")
    ax[-1, 1].set_xlabel("time (s)")
    fig.suptitle(title)
    return save(fig, name)


def bench_figure(runs, p, title, name):
    """Condition (b): θd − θ and va of each controller at 5 kHz; the last 10 ms of va."""
    names = list(CONTROLLERS)
    fig, ax = plt.subplots(len(names), 3, figsize=(11, 7.5), sharex="col",
                           gridspec_kw={"width_ratios": [2, 2, 1]})
    for row, n in enumerate(names):
        r = runs[n]
        t = r["t"]
        ax[row, 0].plot(t, r["load_angle"] / p["Nr"], lw=0.5, color=CONTROLLERS[n]["colour"])
        ax[row, 0].set_ylabel("θd − θ (rad)")
        ax[row, 0].set_title(n, fontsize=9, loc="left")
        ax[row, 1].plot(t, r["voltage_a"], lw=0.4, color="C0")
        z = t >= DURATION - 0.01
        ax[row, 2].plot(t[z], r["voltage_a"][z], lw=0.8, marker=".", ms=2, color="C0")
        for a in ax[row, 1:]:
            a.axhline(p["Vbus"], color="grey", ls="--", lw=0.6)
            a.axhline(-p["Vbus"], color="grey", ls="--", lw=0.6)
            a.set_ylabel("va (V)")
        ax[row, 2].set_title("last 10 ms", fontsize=9, loc="left")
        for a in ax[row]:
            a.grid(alpha=0.3)
    for a in ax[-1]:
        a.set_xlabel("time (s)")
    fig.suptitle(title)
    return save(fig, name)


def sensitivity_figure(p, measured, title, name):
    f = np.logspace(0, np.log10(5000), 400)
    fig, ax = plt.subplots(figsize=(8, 4.8))
    for n, c in CONTROLLERS.items():
        col = c["colour"]
        ax.loglog(f, k35(f, c["k1p"]), color=col, lw=1.2, label=f"{n}: K(35)")
        ax.loglog(f, full_sensitivity(c, p, p["speed"], f), color=col, lw=1, ls="--",
                  label=f"{n}: linearised loop with windings")
        hz = [measured[n][h]["hz"] for h in sorted(measured[n])]
        ax.loglog(hz, [measured[n][h]["ratio"] for h in sorted(measured[n])], "o", color=col, ms=5,
                  label=f"{n}: measured, detent run")
    ax.set_xlabel("torque-ripple frequency (Hz)")
    ax.set_ylabel("J·|E1/T̃| (rad/(N·m)·kg·m²)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=1)
    ax.set_title(title, fontsize=10)
    return save(fig, name)


# --- the study --------------------------------------------------------------------------------------

def main():
    os.makedirs(LOGS, exist_ok=True)
    os.makedirs(FIGS, exist_ok=True)
    os.makedirs(os.path.dirname(REPORT), exist_ok=True)
    start = time.time()
    p = parameters()
    jobs = [(f"{cond}_{c['kind']}{'' if c['rho'] is None else '_' + n[-1]}", n, sets)
            for cond, (_, sets) in CONDITIONS.items() for n, c in CONTROLLERS.items()]
    jobs.append((f"{EXTRA[0]}_foc_2", EXTRA[1], EXTRA[3]))
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:   # both cores
        done = list(pool.map(simulate, jobs))
    runs = {cond: {} for cond in CONDITIONS}
    extra = None
    for (key, name, _), r in zip(jobs, done):
        r["metrics"] = metrics(r, p)
        if key.startswith(EXTRA[0]):
            extra = r
        else:
            runs[key.split("_")[0]][name] = r
    sim_wall = time.time() - start

    figs = {}
    for cond, tag in [("a", "ideal drive, 1 MHz"), ("c", "1 MHz, Tsui's detent harmonics added")]:
        if all("t" in r for r in runs[cond].values()):
            figs[f"fig5_{cond}"] = error_figure(runs[cond], p, f"Kim Fig. 5: position tracking error ({tag})",
                                                f"fig5_position_error_{cond}.png")
            figs[f"fig6_{cond}"] = phase_figure(runs[cond], "voltage", f"Kim Fig. 6: input voltages ({tag})",
                                                f"fig6_voltages_{cond}.png")
            figs[f"fig7_{cond}"] = phase_figure(runs[cond], "current",
                                                f"Kim Fig. 7: current tracking, ia and iad ({tag})",
                                                f"fig7_currents_{cond}.png")
    if all("t" in r for r in runs["b"].values()):
        figs["bench"] = bench_figure(runs["b"], p, "5 kHz control, controller J = plant J",
                                     "bench_5khz.png")
    measured = {n: harmonics(r, p) for n, r in runs["c"].items() if "t" in r}
    if len(measured) == len(CONTROLLERS):
        figs["k35"] = sensitivity_figure(
            p, measured, "Torque ripple → position error at 2π rad/s: eq. K(35), the linearised loop, "
            "the detent runs", "sensitivity_k35.png")
    stability = stability_table(p)
    wall = time.time() - start
    write_report(p, runs, extra, measured, stability, figs, sim_wall, wall)
    print(f"wrote {os.path.relpath(REPORT, ROOT)} and {len(figs)} figures in "
          f"{os.path.relpath(FIGS, ROOT)} ({wall:.0f} s; simulations {sim_wall:.0f} s)")


# --- the report -------------------------------------------------------------------------------------

def sci(x, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if x == 0:
        return "0"
    return f"{x:.{digits}g}" if 1e-2 <= abs(x) < 1e4 else f"{x:.{digits - 1}e}"


def order(values, smaller_first=True):
    """'A < B < C' from {name: value}."""
    items = sorted(values.items(), key=lambda kv: kv[1], reverse=not smaller_first)
    return " < ".join(f"{k} ({sci(v)})" for k, v in items)


def holds(values, expected):
    """Does the measured ordering (ascending) equal `expected` (a list of names, ascending)?"""
    return [k for k, _ in sorted(values.items(), key=lambda kv: kv[1])] == expected


def quote(text, phrase):
    """The phrase as it stands in the paper's text (so the report never misquotes it)."""
    flat = " ".join(text.split())
    if phrase not in flat:
        sys.exit(f"quotation not found in {SEED}: {phrase!r}")
    return f"“{phrase}”"


def write_report(p, runs, extra, measured, stability, figs, sim_wall, wall):
    with open(SEED, encoding="utf-8") as f:
        paper = f.read()
    M = {cond: {n: r["metrics"] for n, r in rs.items()} for cond, rs in runs.items()}
    names = list(CONTROLLERS)
    rows = []
    for cond, (label, _) in CONDITIONS.items():
        for n in names:
            m = M[cond][n]
            if "e1_motion" not in m:
                rows.append(f"| {label} | {n} | " + " | ".join(["—"] * 9) + f" | {m['verdict']} |")
                continue
            rows.append(
                f"| {label} | {n} | {sci(m['e1_motion'])} | {sci(m['e1_transient'])} | "
                f"{sci(m['e1_cruise_pp'])} | {sci(m['e1_end'])} | {m['v_peak']:.2f} | {sci(m['i_rms'])} | "
                f"{100 * m['bus_fraction']:.0f} % | {m['lost_max']:.0f} | {m['verdict']} |")
    if extra is not None and "e1_motion" in extra["metrics"]:
        m = extra["metrics"]
        rows.append(
            f"| {EXTRA[2]} | {EXTRA[1]} | {sci(m['e1_motion'])} | {sci(m['e1_transient'])} | "
            f"{sci(m['e1_cruise_pp'])} | {sci(m['e1_end'])} | {m['v_peak']:.2f} | {sci(m['i_rms'])} | "
            f"{100 * m['bus_fraction']:.0f} % | {m['lost_max']:.0f} | {m['verdict']} |")
    table = "\n".join(rows)

    # precision of the CSV
    gaps = [m["print_gap"] for ms in M.values() for m in ms.values() if "print_gap" in m]
    quantum = max(m["print_quantum"] for ms in M.values() for m in ms.values() if "print_quantum" in m)

    # closed form of the STMMS cruise lag: the winding lags iqd by atan(a), a = Nr·ω·L/R, so the
    # drive must ask (1 + a²)× the torque it gets; the excess comes from k1 + k1p·k2 acting on e1.
    def stmms_lag(L):
        a = p["Nr"] * p["speed"] * L / p["R"]
        tau0 = p["tl"] + p["B"] * p["speed"]
        return a, tau0 * a * a / (p["J"] * (K1 + CONTROLLERS["STMMS"]["k1p"] * K2))
    a_lag, lag = stmms_lag(p["L"])
    _, lag_54 = stmms_lag(5.4e-3)

    # K(35) and the linearised loop at the ripple frequencies
    orders = sorted(next(iter(measured.values()))) if measured else []
    k35_rows = []
    for n, c in CONTROLLERS.items():
        for h in orders:
            hz = measured[n][h]["hz"]
            kk = float(k35(hz, c["k1p"]))
            full = float(full_sensitivity(c, p, p["speed"], [hz])[0])
            meas = measured[n][h]["ratio"]
            h18 = f" (SPEC H18: {sci(H18[n], 4)})" if h == 1 else ""
            k35_rows.append(f"| {n} | {h} | {hz:g} | {sci(kk, 4)}{h18} | {sci(full)} | {sci(meas)} | "
                            f"{meas / kk:.2f} | {meas / full:.3f} | {sci(measured[n][h]['e1'])} |")
    k35_table = "\n".join(k35_rows)
    poles = {}
    for n, c in CONTROLLERS.items():
        ev = np.linalg.eigvals(linearised(c, p, p["speed"])[0])
        osc = [e for e in ev if e.imag > 1 and abs(e.imag) > 2 * abs(p["Nr"] * p["speed"])]
        poles[n] = osc
    stmms_mode = poles["STMMS"][0] if poles["STMMS"] else None

    stab_rows = []
    for n in names:
        s = stability[n]
        mb = M["b"][n]
        num = s.get("bench_numeric")
        stab_rows.append(
            f"| {n} | {s['ideal'][0]:.6f} | {s['bench'][0]:.3f} ({s['bench'][1]:.0f} Hz) | "
            f"{mb.get('rest_frequency', float('nan')):.0f} Hz | "
            + (f"{num[0]:.3f} ({num[1]:.0f} Hz) | " if num else "— (no i̇d) | ")
            + f"{sci(s['max_period'] * 1e6)} µs ({sci(1 / s['max_period'] / 1e3)} kHz) | "
            + (f"{s['max_ratio']:.3f} |" if not math.isnan(s['max_ratio']) else "stable at 1 |"))
    stab_table = "\n".join(stab_rows)

    # --- claims, measured orderings ---
    def claim_lines(metric, expected, what):
        out = []
        for cond, (label, _) in CONDITIONS.items():
            vals = {n: M[cond][n].get(metric) for n in names}
            if any(v is None for v in vals.values()):
                out.append(f"- **{label}**: a run failed; no ordering.")
                continue
            unstable = [n for n in names if M[cond][n]["unstable"]]
            verdict = "holds" if holds(vals, expected) else "does not hold"
            note = ""
            if unstable:
                note = (f" — but {', '.join(unstable)} {'is' if len(unstable) == 1 else 'are'} unstable "
                        "here, so the ordering compares limit cycles, not tracking")
            out.append(f"- **{label}**: {what} {order(vals)}: the paper's order **{verdict}**{note}.")
        return "\n".join(out)

    c1_expected = ["STMMS", "FOC case 2", "FOC case 1"]
    c2_expected = ["STMMS", "FOC case 1", "FOC case 2"]
    c3_expected = ["FOC case 1", "FOC case 2", "STMMS"]
    a, c = M["a"], M["c"]
    foc_max_a = max(a["FOC case 1"]["e1_motion"], a["FOC case 2"]["e1_motion"])
    ratio_a = a["STMMS"]["e1_motion"] / foc_max_a
    pp = {n: c[n]["e1_cruise_pp"] for n in names}
    ripple_holds = holds(pp, c1_expected)
    b_unstable = [n for n in names if M["b"][n]["unstable"]]
    extra_m = extra["metrics"] if extra is not None else {}
    stmms_tr_c = c["STMMS"]["e1_transient"]

    text = f"""# Kim 2016 reproduced

Kim, Shin, Lee, Chung, "Simplified torque modulated microstepping for position control of permanent
magnet stepper motors", Mechatronics 35, 2016, on mjstepper: the STMMS (K(20)-(32), drive `stmms`)
against the high-gain FOC baseline (K(33)-(34), drive `foc`, cases 1 and 2) in Kim's §5 simulation.
Every number below was measured by the command that regenerates this page:

    bash scripts/reproduce_kim2016.sh

(it builds `mjstepper`, then runs `src/tools/python/reproduce_kim2016.py`, which runs the
{sum(len(r) for r in runs.values()) + (extra is not None)} simulations two at a time on the 2-core
machine of BENCHMARKS.md: {sim_wall:.0f} s of simulation and log parsing, {wall:.0f} s in all after
the build). Logs go to `logs/reproduction/kim2016_*.csv`, figures to `renders/kim2016/`.

## Setup

- Models `models/kim_stmms.xml`, `models/kim_foc_case1.xml`, `models/kim_foc_case2.xml`: one
  rotor on a hinge, drive `stmms` or `foc`, the `kim2016` preset as loaded (`mjstepper info`):
  Nr = {p['Nr']}, R = {p['R']:g} Ω, L = {p['L']:g} H, Km = {p['Km']:g} N·m/A; J = {p['J']:g} kg·m² as the
  actuator's armature, B = {p['B']:g} N·m·s/rad as its damping, τl = {p['tl']:g} N·m opposing the
  motion (a `general` actuator named `load`), {p['Vbus']:g} V H-bridges (Kim's Vs), control period
  {p['isr'] * 1e6:g} µs with no computation delay, ideal sensors (exact θ and ω; encoder off), MuJoCo
  step {p['timestep'] * 1e6:g} µs. Gains (Kim §5): k0 = {K0:g}, k1 = {K1:g}, k2 = {K2:g}; STMMS
  k1p = {CONTROLLERS['STMMS']['k1p']:g}; FOC case 1 k1p = {CONTROLLERS['FOC case 1']['k1p']:g},
  ρ = {CONTROLLERS['FOC case 1']['rho']:g}; case 2 k1p = {CONTROLLERS['FOC case 2']['k1p']:g},
  ρ = {CONTROLLERS['FOC case 2']['rho']:g}. The controller's J, B, τl equal the plant's. The FOC's
  i̇ad, i̇bd are `foc_derivative=analytic` (K(27) differentiated along the motion, ω̇ from the
  measured current through the controller's model): the paper does not say how it got them.
- **The motor is a reconstruction.** Kim's Table 1 is lost in the extracted text; SPEC §4 rebuilds
  the `kim2016` row from the PK268-02B class (Km = T_H/(√2·Ir); R, L scaled from sibling Oriental
  motors, "L could be as low as 5.4 mH"; J from the rotor-inertia class). The STMMS's error scales
  with L (below), so every STMMS number here is tied to L = {p['L'] * 1e3:g} mH.
- Trajectory (Kim Fig. 1, SPEC §4), from the drive's own trapezoid profile with target 5π rad:
  θd = 0 until 0.5 s, accelerate at {p['accel']:.4g} rad/s² to {p['speed']:.4g} rad/s by 1.0 s, cruise
  to 3.0 s, decelerate, at rest at 5π from 3.5 s to 4 s.
- Conditions: **(a)** the models as they are (the "ideal continuous-time drive" of SPEC §3);
  **(b)** Kim's bench sampling, `--set shaft.isr_period={BENCH_PERIOD:g}` (5 kHz, still no delay);
  **(c)** (a) plus Tsui 2009's detent harmonics on the motor,
  `--set 'shaft.detent={DETENT}'` (a torque ripple at h·Nr·ω/2π = 50·h Hz at 2π rad/s: the
  "torque ripple's harmonics" Kim blames for the ripple of his experiment).
- e1 = θ − θd. Kim plots θd − θ = −e1, and so do the figures. **CSV precision**: the log prints 10
  significant digits, so θ and θd (up to 15.7 rad) are printed to {quantum:.0e} rad, the size of
  the FOC's whole error under (a). The study therefore reads e1 from the `load_angle` column,
  δ = Nr·(θcmd − θ), which the drive forms in double precision before printing; e1 = −δ/Nr carries
  10 significant digits of itself. Check: |(θ − θd)_printed − (−δ/Nr)| ≤ {max(gaps):.1e} rad in every
  run, i.e. within the printing quantum. Below about 1e-14 rad, e1 is at the double rounding of
  θcmd − θ itself (θ ≈ 15.7 rad).
- "e1 at 4 s" is the last logged sample, t = {a['STMMS']['t_end']:g} s.

## Metrics

Over the motion 0.5-3.5 s unless stated: max |e1|; max |e1| over the acceleration and deceleration
only (0.5-1.0 s and 3.0-3.5 s, Kim's "transient"); e1 peak-to-peak in mid-cruise (1.5-2.5 s, the
ripple); |e1| at the end; peak |v| = max over the run of |va| and |vb|; RMS current error
sqrt(mean((ia − iad)² + (ib − ibd)²)) over 0.5-3.5 s; the share of samples from 0.5 s on with a
phase voltage at the {p['Vbus']:g} V bus; the largest |lost steps| (4·round(δ/2π)) at any time. Verdict: a run
is "unstable" when it has non-finite or huge values, or when a phase still sits at the bus in more
than 1 % of the samples after θd has stopped (3.5-4 s: a limit cycle; the frequency is the peak of
va's spectrum there).

| condition | controller | max \\|e1\\| motion (rad) | max \\|e1\\| accel/decel (rad) | e1 p-p cruise (rad) | \\|e1\\| at 4 s (rad) | peak \\|v\\| (V) | RMS current error (A) | at the bus | max \\|lost steps\\| | verdict |
|---|---|---|---|---|---|---|---|---|---|---|
{table}

## Condition (a): the ideal drive (Kim Figs. 5-7)

![]({figs.get('fig5_a', '')})

![]({figs.get('fig6_a', '')})

![]({figs.get('fig7_a', '')})

The STMMS lags θd by a nearly constant {sci(-a['STMMS']['e1_cruise_mean'])} rad through the cruise. That
lag is the winding's: without current feedback the current follows iad with the time constant L/R,
and at Nr·ω = {p['Nr'] * p['speed']:.0f} rad/s electrical that is a lag of atan(Nr·ω·L/R) =
{math.degrees(math.atan(a_lag)):.1f}° (Nr·ω·L/R = {a_lag:.3f}); the controller must ask
1 + (Nr·ω·L/R)² = {1 + a_lag ** 2:.2f} times the torque it gets, and the extra comes from the position
error through J·(k1 + k1p·k2): e1 ≈ −(τl + B·ω)·(Nr·ω·L/R)²/(J·(k1 + k1p·k2)) =
{sci(-lag)} rad (measured mean {sci(a['STMMS']['e1_cruise_mean'])} rad; the integrator k0 is far too slow
to remove it in 2 s). This is Kim's O(L) error: it grows with L², and with L = 5.4 mH the same
closed form gives {sci(-lag_54)} rad. The FOC's current loop makes the torque equal τd to within
the current error, which decays at ρ; with i̇d fed forward, the reduced error dynamics ė = A·e
of K(26) start at e = 0 and stay there, and only the finite ρ leaves max |e1| =
{sci(a['FOC case 1']['e1_motion'])} rad (case 1) and {sci(a['FOC case 2']['e1_motion'])} rad (case 2).

## Condition (c): torque ripple from the detent (Kim's experiment, Fig. 9)

![]({figs.get('fig5_c', '')})

![]({figs.get('fig6_c', '')})

![]({figs.get('fig7_c', '')})

Eq. K(35) is Kim's own explanation of the ripple: E1/T̃ = (1/J)·s/(s³ + (k1p + k2)s² + (k1 + k1p·k2)s + k0).
The table compares J·|E1/T̃| at each detent harmonic's frequency (h·Nr·ω/2π at 2π rad/s) from K(35),
from the loop linearised about the cruise *with* the winding dynamics and the current law (the
reduced model of K(35) assumes the torque equals τd; see `rotor_frame()` in the script), and as
measured: the e1 amplitude over the detent-torque amplitude at that frequency in the cruise window,
times J.

| controller | h | f (Hz) | K(35) J·\\|E1/T̃\\| | linearised loop | measured | measured / K(35) | measured / linearised | e1 amplitude (rad) |
|---|---|---|---|---|---|---|---|---|
{k35_table}

![]({figs.get('k35', '')})

K(35) reproduces SPEC H18 at 50 Hz and orders the three gain sets by k1p. The FOC case 1 ripple is
what K(35) predicts; case 2's is about twice K(35), because its current loop (ρ = 10 000) is no faster
than its k1p = 10 000, so the torque does not equal τd as K(35) assumes; the STMMS's is
{measured['STMMS'][1]['ratio'] / float(k35(measured['STMMS'][1]['hz'], CONTROLLERS['STMMS']['k1p'])):.1f}-{max(measured['STMMS'][h]['ratio'] / float(k35(measured['STMMS'][h]['hz'], CONTROLLERS['STMMS']['k1p'])) for h in orders):.1f}× K(35), because its
current lags by L/R and the loop through the winding has a lightly damped mode at
{abs(stmms_mode.imag) / (2 * math.pi) if stmms_mode is not None else float('nan'):.0f} Hz (ζ = {(-stmms_mode.real / abs(stmms_mode)) if stmms_mode is not None else float('nan'):.3f}) that K(35) does not have. The
linearised loop with the windings matches every measurement to within
{100 * max(abs(measured[n][h]['ratio'] / float(full_sensitivity(CONTROLLERS[n], p, p['speed'], [measured[n][h]['hz']])[0]) - 1) for n in names for h in orders):.1f} %. Even so the STMMS rejects the
ripple best: its cruise ripple is {pp['FOC case 1'] / pp['STMMS']:.1f}× smaller than case 1's and
{pp['FOC case 2'] / pp['STMMS']:.1f}× smaller than case 2's.

The detent also holds a static error at rest: the integrator (k0 = {K0:g}) is too slow to remove the
detent torque at the final position within 0.5 s, so |e1(4 s)| ≈ |τdet|/(J·(k1 + k1p·k2)), smallest
for the stiffest gains.

## Condition (b): Kim's 5 kHz sampling with the controller's J equal to the plant's

![]({figs.get('bench', '')})

{'All three controllers are' if len(b_unstable) == 3 else (', '.join(b_unstable) + (' is' if len(b_unstable) == 1 else ' are')) if b_unstable else 'No controller is'} unstable at 5 kHz in these runs.
Nothing diverges to NaN: the {p['Vbus']:g} V bus bounds the voltages, so the instability ends in a limit
cycle at the bus (table above). The runs sit exactly at their equilibrium until θd starts to move
at 0.5 s (ideal sensors, no noise), then the oscillation grows from the first motion and persists
after θd stops. STMMS: max |e1| {sci(M['b']['STMMS'].get('e1_motion'))} rad, speed swinging ±{M['b']['STMMS'].get('omega_rest', float('nan')):.0f} rad/s at rest, up to
{M['b']['STMMS'].get('lost_max', float('nan')):.0f} full steps slipped at times (end: {M['b']['STMMS'].get('lost_end', float('nan')):.0f}). FOC case 1: ends {sci(M['b']['FOC case 1'].get('e1_end'))} rad off target.
FOC case 2: ends {sci(M['b']['FOC case 2'].get('e1_end'))} rad off target, still oscillating.

Why, from the sampled loop linearised at rest (q axis: rotor, winding, the drive's law, the voltage
held over each period, e0 summed as the drive sums it; spectral radius ≥ 1 is unstable):

| controller | spectral radius at {p['isr'] * 1e6:g} µs | at 200 µs (oscillation) | measured limit cycle | at 200 µs, numeric i̇d | longest stable period | largest stable controller J / plant J at 5 kHz |
|---|---|---|---|---|---|---|
{stab_table}

SPEC §3 counts ρ·T = {CONTROLLERS['FOC case 1']['rho'] * BENCH_PERIOD:g} (case 1) and k1p·T = {CONTROLLERS['STMMS']['k1p'] * BENCH_PERIOD:g} (STMMS) as the reasons;
the linear analysis refines both and adds case 2. With the analytic i̇d the FOC's voltage contains
L·(k1p + k2)·(Km·iq)/(J·Km)·J = L·(k1p + k2)·iq of current feedback on top of L·ρ·iq (the ω̇ the
controller differentiates comes from the measured current), so its current loop runs at
ρ + k1p + k2: {CONTROLLERS['FOC case 1']['rho'] + CONTROLLERS['FOC case 1']['k1p'] + K2:g}/s (case 1) and {CONTROLLERS['FOC case 2']['rho'] + CONTROLLERS['FOC case 2']['k1p'] + K2:g}/s (case 2), i.e.
{(CONTROLLERS['FOC case 1']['rho'] + CONTROLLERS['FOC case 1']['k1p'] + K2) * BENCH_PERIOD:.2f} and {(CONTROLLERS['FOC case 2']['rho'] + CONTROLLERS['FOC case 2']['k1p'] + K2) * BENCH_PERIOD:.2f} per period, beyond the
deadbeat limit of 2: both oscillate at the Nyquist frequency, 2.5 kHz, as measured. The
backward-difference i̇d does not save case 2 (radius above; the extra run
"{EXTRA[2]}" in the metric table: {extra_m.get('verdict', 'not run')}). The STMMS
has no current loop, and the unstable mode is the winding-loop mode of condition (c) (about
{abs(stmms_mode.imag) / (2 * math.pi) if stmms_mode is not None else float('nan'):.0f} Hz) destabilised by the sampling delay, not k1p·T itself; the last column shows how much
smaller the controller's J (all position gains scale with it) would have to be. Kim's experiment ran at
5 kHz with these gains and was stable, so his bench cannot have had the loop gain these runs have
(a different J in the controller, a filtered speed, or other gains); the paper does not say.

## Claims C1-C3 against the paper

**C1, position error: STMMS < FOC case 2 < FOC case 1** (Figs. 5, 9). Paper:
{quote(paper, "the overshoots in the position tracking error appeared during the acceleration and deceleration periods")}
(case 1); {quote(paper, "the larger position control gain gave us the improvement of the position tracking performance during the transient response")}
(case 2); {quote(paper, "the position tracking error of the STMMS was the smallest among three cases")}.

{claim_lines('e1_transient', c1_expected, 'max |e1| during acceleration and deceleration:')}
- Cruise ripple (e1 p-p 1.5-2.5 s) under **(c)**: {order(pp)}: the paper's order
  **{'holds' if ripple_holds else 'does not hold'}** for the ripple.

Under (a) the ordering is reversed: the STMMS's error is {ratio_a:.0f}× the larger FOC's. Kim's
singular-perturbation argument makes the STMMS error O(L), and with this reconstructed L that is
{sci(a['STMMS']['e1_motion'])} rad, while an ideal continuous FOC tracks the current, hence the torque,
almost exactly. The paper's simulation shows the opposite; with Table 1 lost we cannot tell which of
its parameters (a smaller L, a different J in the controller) or of its implementation details
(how i̇d was formed, the solver) made its FOC worse. Under (c) the order of K(35) appears in the
ripple, as Kim's experiment (Fig. 9) reports and explains with K(35): a higher k1p rejects torque ripple
better. In the acceleration and deceleration windows under (c) the STMMS's max |e1|
({sci(stmms_tr_c)} rad) is still dominated by its O(L) lag, not by the ripple. Under (b) nothing
tracks.

**C2, peak voltage: STMMS < FOC case 1 < FOC case 2** (Figs. 6, 10). Paper:
{quote(paper, "the STMMS had the smallest input voltages since the high electrical control gain part was not used")};
{quote(paper, "In Case 2, the high mechanical control gain")} … {quote(paper, "resulted in the largest input voltages")}.

{claim_lines('v_peak', c2_expected, 'peak |v|:')}

In the ideal simulation the FOC's high gain costs no voltage: its current error is tiny, so
L·ρ·(iad − ia) is tiny, and its voltage is R·i + L·i̇d + back-EMF, about the back-EMF
Km·ω = {p['Km'] * p['speed']:.2f} V plus little. The STMMS applies R·iad + back-EMF with
iad {1 + a_lag ** 2:.2f}× the current it needs (the lag above), hence the larger peak. The paper's
ordering needs something for the high gain to amplify (noise, quantisation, ripple): under (c) the
detent ripple is not enough. Under (b) every controller sits at the bus.

**C3, current tracking: FOC case 1 best, STMMS worst** (Figs. 7, 11). Paper:
{quote(paper, "We see that the FOC (Case 1) had the best current tracking performance")};
{quote(paper, "The STMMS had the poor current tracking performance since the STMMS did not use the high gain in the current-loop")}.

{claim_lines('i_rms', c3_expected, 'RMS current error:')}

Reproduced under (a) and (c): the current error decays at ρ in the FOC (25 000/s in case 1,
10 000/s in case 2) and only at R/L = {p['R'] / p['L']:.0f}/s in the STMMS. The paper's conclusion that
{quote(paper, "high performance in the current tracking does not necessarily entail high performance in the position tracking")}
is borne out under (c) (best current tracking, case 1, has the largest ripple), not under (a).

## Summary

| claim | (a) ideal, 1 MHz | (b) 5 kHz | (c) 1 MHz + detent |
|---|---|---|---|
"""
    summary = []
    for label, metric, expected in [("C1 max \\|e1\\| accel/decel", "e1_transient", c1_expected),
                                    ("C2 peak \\|v\\|", "v_peak", c2_expected),
                                    ("C3 current error", "i_rms", c3_expected)]:
        cells = []
        for cond in CONDITIONS:
            vals = {n: M[cond][n].get(metric) for n in names}
            if any(v is None for v in vals.values()):
                cells.append("run failed")
            elif any(M[cond][n]["unstable"] for n in names):
                cells.append(("holds" if holds(vals, expected) else "does not hold") + " (unstable runs)")
            else:
                cells.append("holds" if holds(vals, expected) else "does not hold")
        summary.append(f"| {label} | " + " | ".join(cells) + " |")
    summary.append(f"| C1 cruise ripple | — | — | {'holds' if ripple_holds else 'does not hold'} |")
    text += "\n".join(summary) + "\n"
    with open(REPORT + ".tmp", "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(REPORT + ".tmp", REPORT)


if __name__ == "__main__":
    main()

"""The real LinuxCNC, headless, driven from the tests (nothing of vecpin runs inside it).

A simulation configuration is built for a machine's joints around the files vecpin
wrote (``[JOINT_n] COMP_FILE``, the HAL component ``vecpin_vec`` built with
``halcompile --install``); ``linuxcnc`` starts it as an ordinary user (its realtime
layer refuses root) with a small driver as its display, which switches the machine on,
homes it in place, moves to each command with ``G53 G1`` in MDI and reads the HAL pins
of every joint. What the controller did to a joint is ``motor-pos-cmd - pos-cmd``
(COMP_FILE) plus the component's ``correction-N``; on the simulated machine the drive's
feedback is its command (``motor-pos-cmd-out-N``).

Needs: the Debian packages ``linuxcnc-uspace`` and ``linuxcnc-uspace-dev`` (`.ci/run`
installs them), root (to install the component and to run LinuxCNC as the user
``vecpin-lcnc``). :func:`unavailable` says why a test must be skipped.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

USER = "vecpin-lcnc"
HAL_NAME = "vecpin-vec"
MODULES = Path("/usr/lib/linuxcnc/modules")

DRIVER = r'''#!/usr/bin/python3
"""Drive LinuxCNC: on, home in place, G53 G1 to each command, read the joints' HAL pins."""
import json, sys, time
import hal, linuxcnc
cfg = json.load(open("commands.json"))
probe = hal.component("vecpin-driver")  # hal.get_value needs a component of this process
probe.ready()
s, c = linuxcnc.stat(), linuxcnc.command()
def wait(cond, t=30.0):
    t0 = time.time()
    while time.time() - t0 < t:
        s.poll()
        if cond():
            return True
        time.sleep(0.01)
    return False
out = {"error": None, "rows": []}
try:
    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.state(linuxcnc.STATE_ON)
    if not wait(lambda: s.task_state == linuxcnc.STATE_ON):
        raise RuntimeError("machine did not switch on")
    c.home(-1)
    if not wait(lambda: all(s.homed[:cfg["joints"]])):
        raise RuntimeError("joints did not home")
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    pins = cfg["pins"]
    for cmd in cfg["commands"]:
        # fast to 0.01 short of the command on every joint, then creep to it: the COMP_FILE trim is
        # looked up while a joint moves (control.c), so the last step before the stop must be small
        for dq, feed in ((cfg["creep"], 1000000), (0.0, 6)):
            c.mdi(f"G53 G1 F{feed} " + " ".join(f"{k}{v - dq:.9f}" for k, v in zip(cfg["letters"], cmd)))
            if c.wait_complete(60) == -1:
                raise RuntimeError("move timed out")
        if not wait(lambda: s.inpos and s.state == linuxcnc.RCS_DONE, 120.0):  # a loaded machine is slow
            raise RuntimeError("not in position")
        s.poll()
        if s.task_state != linuxcnc.STATE_ON:
            raise RuntimeError(f"controller left the ON state after {cmd}")
        time.sleep(0.3)  # let the comp ramps (backlash_filt, the component's fade-in) settle
        out["rows"].append({p: hal.get_value(p) for p in pins})
except Exception as exc:
    out["error"] = repr(exc)
json.dump(out, open("result.json", "w"))
c.state(linuxcnc.STATE_OFF)
'''


def unavailable() -> str | None:
    """Why the real controller cannot run here (None: it can)."""
    if shutil.which("linuxcnc") is None or shutil.which("halcompile") is None:
        return "LinuxCNC is not installed (Debian packages linuxcnc-uspace and linuxcnc-uspace-dev; .ci/run installs them)"
    if os.geteuid() != 0:
        return "installing a HAL component and running LinuxCNC as another user need root"
    if not Path("/usr/bin/python3").exists():
        return "LinuxCNC's Python module needs the system /usr/bin/python3"
    return None


def ensure_user() -> None:
    if subprocess.run(["id", USER], capture_output=True).returncode != 0:
        subprocess.run(["useradd", "-m", USER], check=True, capture_output=True)


def install_component(comp_file: Path) -> None:
    """``halcompile --install`` (the module lands in LinuxCNC's module folder)."""
    work = comp_file.parent
    r = subprocess.run(["halcompile", "--install", comp_file.name], cwd=work, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"halcompile failed:\n{r.stdout}\n{r.stderr}")


def _ini(letters: list[str], kinds: list[str], limits: list[tuple[float, float]], comp: dict[int, tuple[str, int]],
         coordinates: str) -> str:
    lines = ["[EMC]", "VERSION = 1.1", "MACHINE = vecpin-test", "[DISPLAY]", "DISPLAY = ./driver.py",
             "CYCLE_TIME = 0.05", "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "[RS274NGC]",
             "PARAMETER_FILE = sim.var", "[EMCMOT]", "EMCMOT = motmod", "COMM_TIMEOUT = 1.0",
             "SERVO_PERIOD = 1000000", "[EMCIO]", "EMCIO = io", "CYCLE_TIME = 0.100", "TOOL_TABLE = sim.tbl",
             "[HAL]", "HALFILE = sim.hal", "[TRAJ]", "COORDINATES = " + " ".join(coordinates),
             "LINEAR_UNITS = mm", "ANGULAR_UNITS = degree", "MAX_LINEAR_VELOCITY = 100000",
             "MAX_ANGULAR_VELOCITY = 100000", "[KINS]", f"KINEMATICS = trivkins coordinates={coordinates}",
             f"JOINTS = {len(letters)}"]
    for j, (letter, kind, (lo, hi)) in enumerate(zip(letters, kinds, limits)):
        if letter not in letters[:j]:
            lines += [f"[AXIS_{letter}]", "MAX_VELOCITY = 100000", "MAX_ACCELERATION = 1000000",
                      f"MIN_LIMIT = {lo}", f"MAX_LIMIT = {hi}"]
        lines += [f"[JOINT_{j}]", f"TYPE = {'LINEAR' if kind == 'linear' else 'ANGULAR'}", "HOME = 0",
                  "MAX_VELOCITY = 100000", "MAX_ACCELERATION = 1000000", f"MIN_LIMIT = {lo}", f"MAX_LIMIT = {hi}",
                  "FERROR = 1000", "MIN_FERROR = 1000", "HOME_OFFSET = 0", "HOME_SEARCH_VEL = 0",
                  "HOME_LATCH_VEL = 0", "HOME_SEQUENCE = 0"]
        if j in comp:
            lines += [f"COMP_FILE = {comp[j][0]}", f"COMP_FILE_TYPE = {comp[j][1]}"]
    return "\n".join(lines) + "\n"


def _hal(n: int, component: bool) -> str:
    lines = ["loadrt [KINS]KINEMATICS",
             "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
             "addf motion-command-handler servo-thread", "addf motion-controller servo-thread",
             "net estop-loop iocontrol.0.user-enable-out iocontrol.0.emc-enable-in",
             "net tool-prep-loop iocontrol.0.tool-prepare iocontrol.0.tool-prepared",
             "net tool-change-loop iocontrol.0.tool-change iocontrol.0.tool-changed"]
    if not component:
        lines += [f"net j{j} joint.{j}.motor-pos-cmd => joint.{j}.motor-pos-fb" for j in range(n)]
    return "\n".join(lines) + "\n"


def run(folder: Path, letters: list[str], kinds: list[str], limits: list[tuple[float, float]],
        commands: list[list[float]], comp_files: dict[int, tuple[str, int]], hal_file: str | None = None,
        timeout: float = 300.0) -> list[dict]:
    """Run LinuxCNC on a configuration in ``folder`` (which holds the comp files and the
    HAL file vecpin wrote): joint ``j`` is axis ``letters[j]`` of kind ``kinds[j]``,
    travel ``limits[j]`` (mm/deg), ``comp_files[j]`` = (file name, COMP_FILE_TYPE);
    ``hal_file``: vecpin's HAL file for the component (its drive nets are completed
    here: the simulated drive's feedback is its command). Returns, per command, the
    pins of every joint (``joint.j.pos-cmd``, ``joint.j.motor-pos-cmd`` and, with the
    component, ``vecpin-vec.0.correction-j`` / ``motor-pos-cmd-out-j``)."""
    n = len(letters)
    work = Path(tempfile.mkdtemp(prefix="vecpin-lcnc-"))     # in /tmp: the user can reach it
    for f in Path(folder).iterdir():
        if f.is_file():
            shutil.copy(f, work)
    folder = work
    coordinates = "".join(letters)
    (folder / "sim.ini").write_text(_ini(letters, kinds, limits, comp_files, coordinates))
    hal = _hal(n, hal_file is not None)
    pins = [f"joint.{j}.{p}" for j in range(n) for p in ("pos-cmd", "motor-pos-cmd")]
    if hal_file is not None:
        text = (folder / hal_file).read_text()
        lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        lines += [f"net vecpin-j{j}-drive {HAL_NAME}.0.motor-pos-cmd-out-{j} => {HAL_NAME}.0.motor-pos-fb-{j}"
                  for j in range(n)]
        hal += "\n".join(lines) + "\n"
        pins += [f"{HAL_NAME}.0.{p}-{j}" for j in range(n) for p in ("correction", "motor-pos-cmd-out")]
    (folder / "sim.hal").write_text(hal)
    (folder / "sim.tbl").write_text("T1 P1 Z0 ;\n")
    (folder / "sim.var").write_text("")
    (folder / "driver.py").write_text(DRIVER)
    (folder / "driver.py").chmod(0o755)
    (folder / "commands.json").write_text(json.dumps({"joints": n, "letters": letters, "pins": pins,
                                                      "commands": commands, "creep": 0.01}))
    ensure_user()
    subprocess.run(["pkill", "-KILL", "-u", USER], capture_output=True)   # what an earlier, killed run left
    subprocess.run(["chown", "-R", USER, str(folder)], check=True)
    folder.chmod(0o755)
    r = subprocess.run(["runuser", "-u", USER, "--", "bash", "-c", f"cd {folder} && linuxcnc sim.ini"],
                       capture_output=True, text=True, timeout=timeout)
    res = folder / "result.json"
    if not res.exists():
        raise RuntimeError(f"LinuxCNC wrote no result (exit {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    out = json.loads(res.read_text())
    if out["error"]:
        raise RuntimeError(f"LinuxCNC driver: {out['error']}\n{r.stdout[-2000:]}")
    shutil.rmtree(work, ignore_errors=True)
    return out["rows"]


class ControllerCommands:
    """The commands a controller run produced, in the place of a TableSet where vecpin
    judges a compensated machine (``compensated_errors``): ``apply(q)`` returns what the
    controller sent to the joints for the commands ``q`` it was given (SI), in order."""

    def __init__(self, q: np.ndarray, qc: np.ndarray, gauge_offset_change: float):
        self.q, self.qc, self.gauge_offset_change = q, qc, gauge_offset_change

    def apply(self, q):
        q = np.atleast_2d(q)
        reps = len(q) // len(self.q)
        if reps * len(self.q) != len(q) or not np.allclose(q, np.tile(self.q, (reps, 1)), atol=1e-9):
            raise ValueError("judged on other commands than the controller ran")
        return np.tile(self.qc, (reps, 1))

    def turn_tips(self, machine, q, tip, frame="base"):
        return tip


def machine_run(m, folder: Path, q, joints: dict[str, int], kind: int, component: bool):
    """vecpin's LinuxCNC files in ``folder`` on the real controller, commanded to ``q``
    (N, n) [m, rad], joints numbered ``joints``: (commanded positions, COMP_FILE part, component
    part), each (N, n) in mm/deg, axes in the machine's order."""
    order = sorted(m.axis_names, key=lambda a: joints[a])          # the configuration's joint order
    ax = [m.axis(a) for a in order]
    limits = [(float(a.to_user(a.lower - 0.1 * a.travel)), float(a.to_user(a.upper + 0.1 * a.travel))) for a in ax]
    commands = [[float(a.to_user(row[a.index])) for a in ax] for row in np.atleast_2d(q)]
    comp = {joints[a]: (f"comp_{a}.txt", kind) for a in m.axis_names if (Path(folder) / f"comp_{a}.txt").exists()}
    rows = run(folder, order, [a.kind for a in ax], limits, commands, comp, "vecpin_vec.hal" if component else None)
    pos = np.array([[r[f"joint.{joints[a]}.pos-cmd"] for a in m.axis_names] for r in rows])
    pitch = np.array([[r[f"joint.{joints[a]}.motor-pos-cmd"] for a in m.axis_names] for r in rows]) - pos
    cross = (np.array([[r[f"{HAL_NAME}.0.correction-{joints[a]}"] for a in m.axis_names] for r in rows])
             if component else np.zeros_like(pitch))
    if component:
        out = np.array([[r[f"{HAL_NAME}.0.motor-pos-cmd-out-{joints[a]}"] for a in m.axis_names] for r in rows])
        if np.abs(out - pos - pitch - cross).max() > 1e-9:
            raise RuntimeError("the component's output is not motor-pos-cmd + correction")
    return pos, pitch, cross


def to_si(m, values_user):
    """(N, n) mm/deg -> m/rad, axes in the machine's order."""
    return np.column_stack([m.axes[k].to_si(values_user[:, k]) for k in range(len(m.axes))])

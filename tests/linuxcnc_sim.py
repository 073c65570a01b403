"""The real LinuxCNC, headless, driven from the tests (nothing of vecpin runs inside it).

A simulation configuration is built for a machine's joints around the files vecpin
wrote (``[JOINT_n] COMP_FILE``, the HAL component ``vecpin_vec`` built with
``halcompile --compile`` and installed for the run: one run at a time on a machine);
``linuxcnc`` starts it as an ordinary user (its realtime layer refuses root) with a
small driver as its display (tests/linuxcnc_driver.py), which switches the machine on,
homes it in place, moves to each command with ``G53 G1`` in MDI, checks the controller
after every move (error channel, task state, motion enabled) and reads the HAL pins
and following errors of every joint. What the
controller did to a joint is ``motor-pos-cmd - pos-cmd`` (COMP_FILE) plus what the
component added on the way to the drive (``drive-N.out - motor-pos-cmd``). The
simulated drive of a joint (``drive-N``, a ``scale`` of gain 1) reads its position first
in the servo thread, as a Mesa card's ``read`` does: the command of the last servo
period, reached exactly; its feedback goes back to motion through the component, whose
feedback function runs after the drives' reads and before motion.

The joints have the following-error limits of LinuxCNC's sample configurations
(:data:`FERROR`), so a component that breaks the feedback faults the controller, and
every run checks the feedback path (:func:`feedback_problems`): motion's following
error is 0 at rest, and a stalled drive trips a following error.

Needs: the Debian packages ``linuxcnc-uspace`` and ``linuxcnc-uspace-dev`` (`.ci/run`
installs them), root (to install the component and to run LinuxCNC as the user
``vecpin-lcnc``). :func:`unavailable` says why a test must be skipped.
"""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

USER = "vecpin-lcnc"
HAL_NAME = "vecpin-vec"
COMPONENT = "vecpin_vec"                          # the component: vecpin_vec.comp, .hal, .so
MODULES = Path("/usr/lib/linuxcnc/modules")
LOCK = Path("/tmp/vecpin-linuxcnc.lock")

DRIVER = Path(__file__).with_name("linuxcnc_driver.py")   # LinuxCNC's display: moves, checks, reads
# Following-error limits, from LinuxCNC's sample configurations: linear joints as
# sim/axis/axis_mm.ini (FERROR = 1.27, MIN_FERROR = 0.254 mm: axis.ini's 0.050 and 0.010 in),
# angular joints as by_machine/sherline/Sherline4Axis/Sherline4Axis_mm.ini and
# sim/gmoccapy/gmoccapy_XYZAC.ini (FERROR = 5.0, MIN_FERROR = 1.0 deg). Motion's limit is
# FERROR * |joint velocity| / MAX_VELOCITY, not below MIN_FERROR (control.c): 0.254 mm at
# rest, 1.27 mm at full speed.
FERROR = {"linear": (1.27, 0.254), "rotary": (5.0, 1.0)}
FULL_TRAVEL_S = 0.25    # s: a joint's MAX_VELOCITY crosses its travel (with the margins) in this time
STALL_STEP = 10.0       # mm or deg: how far the joints are commanded with the drives stalled


class ControllerFault(RuntimeError):
    """LinuxCNC reported an error (its error channel: e.g. "joint 0 following error") or
    left the ON state while it moved to the commands; ``errors``: the controller's errors."""

    def __init__(self, message: str, errors: list[str]):
        super().__init__(message)
        self.errors = errors


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


def build_component(comp_file: Path) -> None:
    """``halcompile --compile``: the module (``vecpin_vec.so``) is built beside its source;
    :func:`run` installs it in LinuxCNC's module folder, under the lock, just before it
    starts LinuxCNC."""
    work = comp_file.parent
    r = subprocess.run(["halcompile", "--compile", comp_file.name], cwd=work, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"halcompile failed:\n{r.stdout}\n{r.stderr}")


@contextmanager
def _one_linuxcnc():
    """One LinuxCNC at a time on this machine, across processes (test workers, other
    checkouts): its realtime layer, the user and the installed module are shared."""
    with open(LOCK, "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _ini(letters: list[str], kinds: list[str], limits: list[tuple[float, float]], comp: dict[int, tuple[str, int]],
         coordinates: str) -> str:
    lines = ["[EMC]", "VERSION = 1.1", "MACHINE = vecpin-test", "[DISPLAY]", "DISPLAY = ./driver.py",
             "CYCLE_TIME = 0.05", "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "[RS274NGC]",
             "PARAMETER_FILE = sim.var", "[EMCMOT]", "EMCMOT = motmod", "COMM_TIMEOUT = 10.0",
             "SERVO_PERIOD = 1000000", "[EMCIO]", "EMCIO = io", "CYCLE_TIME = 0.100", "TOOL_TABLE = sim.tbl",
             "[HAL]", "HALFILE = sim.hal", "[TRAJ]", "COORDINATES = " + " ".join(coordinates),
             "LINEAR_UNITS = mm", "ANGULAR_UNITS = degree", "MAX_LINEAR_VELOCITY = 100000",
             "MAX_ANGULAR_VELOCITY = 100000", "[KINS]", f"KINEMATICS = trivkins coordinates={coordinates}",
             f"JOINTS = {len(letters)}"]
    for j, (letter, kind, (lo, hi)) in enumerate(zip(letters, kinds, limits)):
        vel = (hi - lo) / FULL_TRAVEL_S
        motion = [f"MAX_VELOCITY = {vel:.6g}", f"MAX_ACCELERATION = {10 * vel:.6g}"]
        if letter not in letters[:j]:
            lines += [f"[AXIS_{letter}]", *motion, f"MIN_LIMIT = {lo}", f"MAX_LIMIT = {hi}"]
        ferror, min_ferror = FERROR["linear" if kind == "linear" else "rotary"]
        lines += [f"[JOINT_{j}]", f"TYPE = {'LINEAR' if kind == 'linear' else 'ANGULAR'}", "HOME = 0", *motion,
                  f"MIN_LIMIT = {lo}", f"MAX_LIMIT = {hi}", f"FERROR = {ferror}", f"MIN_FERROR = {min_ferror}",
                  "HOME_OFFSET = 0", "HOME_SEARCH_VEL = 0", "HOME_LATCH_VEL = 0", "HOME_SEQUENCE = 0"]
        if j in comp:
            lines += [f"COMP_FILE = {comp[j][0]}", f"COMP_FILE_TYPE = {comp[j][1]}"]
    return "\n".join(lines) + "\n"


def _hal(n: int, component: bool) -> str:
    """The machine's own HAL: motion, and per joint a simulated drive whose function reads
    its position first in the servo thread (as a Mesa card's ``read`` does): the command
    of the last servo period, reached exactly. Without the component the drives are
    wired to motion directly; with it, :func:`run` wires them to the component."""
    lines = ["loadrt [KINS]KINEMATICS",
             "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
             "addf motion-command-handler servo-thread", "addf motion-controller servo-thread",
             "net estop-loop iocontrol.0.user-enable-out iocontrol.0.emc-enable-in",
             "net tool-prep-loop iocontrol.0.tool-prepare iocontrol.0.tool-prepared",
             "net tool-change-loop iocontrol.0.tool-change iocontrol.0.tool-changed",
             "loadrt scale names=" + ",".join(f"drive-{j}" for j in range(n))]
    for j in range(n):
        lines += [f"addf drive-{j} servo-thread {j + 1}", f"setp drive-{j}.gain 1.0", f"setp drive-{j}.offset 0.0"]
        if not component:
            lines += [f"net j{j}-cmd joint.{j}.motor-pos-cmd => drive-{j}.in",
                      f"net j{j}-fb drive-{j}.out => joint.{j}.motor-pos-fb"]
    return "\n".join(lines) + "\n"


def run(folder: Path, letters: list[str], kinds: list[str], limits: list[tuple[float, float]],
        commands: list[list[float]], comp_files: dict[int, tuple[str, int]], hal_file: str | None = None,
        stall: bool = True, timeout: float = 300.0, component: str | list[str] = COMPONENT,
        setp: list[dict] | None = None, getp: list[str] | None = None) -> dict:
    """Run LinuxCNC on a configuration in ``folder`` (which holds the comp files and the
    HAL file vecpin wrote): joint ``j`` is axis ``letters[j]`` of kind ``kinds[j]``,
    travel ``limits[j]`` (mm/deg), ``comp_files[j]`` = (file name, COMP_FILE_TYPE);
    ``hal_file``: vecpin's HAL file for the component (its drive nets are completed
    here, and its feedback function goes after the drives' reads, as its comment says).
    Returns the driver's result: ``rows``, per command, the pins of every joint
    (``joint.j.pos-cmd``, ``motor-pos-cmd``, ``motor-pos-fb``, ``pos-fb``, the drive's
    position ``drive-j.out`` and, with the component, ``vecpin-vec.0.correction-j`` /
    ``motor-pos-cmd-out-j``), ``ferror`` (motion's following error per joint, at rest)
    and ``ferror_highmark`` (its largest so far, moves included); ``limits`` (motion's
    ``min_ferror`` / ``max_ferror`` per joint); ``stall`` (with ``stall``: the
    controller's errors after the drives stalled and the joints moved on). Raises
    :class:`ControllerFault` when the controller reported an error or left the ON state
    before that. ``component``: the HAL component of ``hal_file`` (default vecpin's cross
    tables; vecpin_thermal: the thermal terms), or components and their HAL files, lists in
    the order of the chain from motion to the drive (the last one's outputs drive);
    ``setp``: per command, HAL pins the driver sets with ``halcmd setp`` before it moves
    there; ``getp``: pins it then reads with ``halcmd getp`` (in ``rows`` too)."""
    n = len(letters)
    hal_files = [] if hal_file is None else [hal_file] if isinstance(hal_file, str) else list(hal_file)
    comps = [component] if isinstance(component, str) else list(component)
    modules = [Path(folder) / (c + ".so") for c in comps] if hal_files else []
    for module in modules:
        if not module.exists():
            raise RuntimeError(f"no {module.name} in {folder}: build the component first (build_component)")
    work = Path(tempfile.mkdtemp(prefix="vecpin-lcnc-"))     # in /tmp: the user can reach it
    for f in Path(folder).iterdir():
        if f.is_file():
            shutil.copy(f, work)
    folder = work
    coordinates = "".join(letters)
    (folder / "sim.ini").write_text(_ini(letters, kinds, limits, comp_files, coordinates))
    hal = _hal(n, bool(hal_files))
    pins = [f"joint.{j}.{p}" for j in range(n) for p in ("pos-cmd", "motor-pos-cmd", "motor-pos-fb", "pos-fb")]
    pins += [f"drive-{j}.out" for j in range(n)]
    if hal_files:
        names = [c.replace("_", "-") for c in comps]
        lines = [ln for f in hal_files for ln in (folder / f).read_text().splitlines()
                 if ln.strip() and not ln.lstrip().startswith("#")]
        # as its comment says: the feedback function goes after the drives' reads (positions 1..n); a later
        # file's goes before an earlier one's there: the feedback runs the chain from the drive back to motion
        lines = [f"addf {ln.split()[1]} servo-thread {n + 1}"
                 if ln.split() in (["addf", f"{h}.0.feedback", "servo-thread", "1"] for h in names) else ln
                 for ln in lines]
        for j in range(n):
            lines += [f"net vecpin-j{j}-drive-cmd {names[-1]}.0.motor-pos-cmd-out-{j} => drive-{j}.in",
                      f"net vecpin-j{j}-drive-fb drive-{j}.out => {names[-1]}.0.motor-pos-fb-{j}"]
        hal += "\n".join(lines) + "\n"
        pins += [f"{h}.0.{p}-{j}" for h in names for j in range(n) for p in ("correction", "motor-pos-cmd-out")]
    drive_in = [f"drive-{j}.in" for j in range(n)]
    last = commands[-1]
    step = [STALL_STEP if v < 0.5 * (lo + hi) else -STALL_STEP for v, (lo, hi) in zip(last, limits)]  # inward
    (folder / "sim.hal").write_text(hal)
    (folder / "sim.tbl").write_text("T1 P1 Z0 ;\n")
    (folder / "sim.var").write_text("")
    shutil.copy(DRIVER, folder / "driver.py")
    (folder / "driver.py").chmod(0o755)
    (folder / "commands.json").write_text(json.dumps({"joints": n, "letters": letters, "pins": pins,
                                                      "commands": commands, "creep": 0.01, "setp": setp, "getp": getp,
                                                      "stall": drive_in if stall else None, "stall_step": step}))
    ensure_user()
    subprocess.run(["chown", "-R", USER, str(folder)], check=True)
    folder.chmod(0o755)
    with _one_linuxcnc():
        subprocess.run(["pkill", "-KILL", "-u", USER], capture_output=True)   # what an earlier, killed run left
        for module in modules:
            shutil.copy(module, MODULES / module.name)
        r = subprocess.run(["runuser", "-u", USER, "--", "bash", "-c", f"cd {folder} && linuxcnc sim.ini"],
                           capture_output=True, text=True, timeout=timeout)
    res = folder / "result.json"
    if not res.exists():
        raise RuntimeError(f"LinuxCNC wrote no result (exit {r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    out = json.loads(res.read_text())
    if out["error"]:
        raise ControllerFault(f"LinuxCNC: {out['error']} (errors: {out['errors']}, configuration in {work})",
                              out["errors"])
    shutil.rmtree(work, ignore_errors=True)
    return out


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


@dataclass
class Readback:
    """What the controller did at each command, (N, n) in mm or deg, axes in the machine's order."""
    names: list[str]           # the axes
    pos: np.ndarray            # joint.N.pos-cmd: the commanded joint position
    pitch: np.ndarray          # motor-pos-cmd - pos-cmd: motion's COMP_FILE trim
    cross: np.ndarray          # drive position - motor-pos-cmd: what the component added on the way (0 without)
    correction: np.ndarray     # the component's correction-N pin (what it says it added; 0 without)
    ferror: np.ndarray         # motion's following error at rest, pos-cmd - pos-fb (task status)
    ferror_moving: np.ndarray  # (n,) its largest over the run, moves included (task status: ferror_highmark)
    fb_offset: np.ndarray      # drive position - joint.N.motor-pos-fb: what the feedback path took off
    min_ferror: np.ndarray     # (n,) motion's following-error limits in force, at rest and at full speed
    max_ferror: np.ndarray
    stall_errors: list[str] | None   # the controller's errors once the drives stalled (None: not run)


def machine_readback(m, folder: Path, q, joints: dict[str, int], kind: int, component: bool,
                     stall: bool = True) -> Readback:
    """vecpin's LinuxCNC files in ``folder`` on the real controller, commanded to ``q``
    (N, n) [m, rad], joints numbered ``joints``; raises :class:`ControllerFault` when the
    controller faults on the way (a following error, say)."""
    order = sorted(m.axis_names, key=lambda a: joints[a])          # the configuration's joint order
    ax = [m.axis(a) for a in order]
    limits = [(float(a.to_user(a.lower - 0.1 * a.travel)), float(a.to_user(a.upper + 0.1 * a.travel))) for a in ax]
    commands = [[float(a.to_user(row[a.index])) for a in ax] for row in np.atleast_2d(q)]
    comp = {joints[a]: (f"comp_{a}.txt", kind) for a in m.axis_names if (Path(folder) / f"comp_{a}.txt").exists()}
    out = run(folder, order, [a.kind for a in ax], limits, commands, comp, "vecpin_vec.hal" if component else None,
              stall)
    rows = out["rows"]

    def pins(name):
        return np.array([[r[name.format(j=joints[a])] for a in m.axis_names] for r in rows])
    pos, motor = pins("joint.{j}.pos-cmd"), pins("joint.{j}.motor-pos-cmd")
    drive = pins("drive-{j}.out")
    correction = pins(HAL_NAME + ".0.correction-{j}") if component else np.zeros_like(pos)
    ferror = np.array([[r["ferror"][joints[a]] for a in m.axis_names] for r in rows])
    lim = out["limits"]
    highmark = np.array([rows[-1]["ferror_highmark"][joints[a]] for a in m.axis_names])
    return Readback(list(m.axis_names), pos, motor - pos, drive - motor, correction, ferror, highmark,
                    drive - pins("joint.{j}.motor-pos-fb"),
                    np.array([lim[joints[a]]["min_ferror"] for a in m.axis_names]),
                    np.array([lim[joints[a]]["max_ferror"] for a in m.axis_names]),
                    None if out["stall"] is None else out["stall"]["errors"])


def feedback_problems(rb: Readback, tol: float) -> list[str]:
    """What is wrong with the feedback path in a run (tolerance ``tol`` in mm or deg), in
    words; [] when sound. The simulated drive reaches each command exactly, one servo
    period later, when its function reads it first in the thread; motion compares the
    feedback with the command of the last period, so its following error must be 0 at
    rest, and while moving too: a feedback that keeps some of the component's
    correction, or takes it off twice, shows at rest; one that reaches motion a servo
    period late shows while moving (``velocity * period``; at full speed above the
    limit: a fault). The component's correction pin must be what reached the drive. With
    the drives stalled, motion must trip a following error: a feedback that is not the
    drive's does not."""
    out = []
    for k, a in enumerate(rb.names):
        worst = np.abs(rb.ferror[:, k]).max()
        if worst > tol:
            out.append(f"{a}: motion's following error at rest is {worst:.4g} mm or deg (pos-cmd - pos-fb), "
                       f"where the drive sits at the corrected command: the feedback does not take off "
                       f"exactly what the command got (the drive's position less motion's motor-pos-fb: "
                       f"{np.abs(rb.fb_offset[:, k]).max():.4g}, correction {np.abs(rb.cross[:, k]).max():.4g})")
        if rb.ferror_moving[k] > tol and worst <= tol:
            out.append(f"{a}: motion's following error reached {rb.ferror_moving[k]:.4g} mm or deg while moving, where "
                       f"the simulated drive follows its command exactly: the feedback reaches motion late")
        off = np.abs(rb.correction[:, k] - rb.cross[:, k]).max()
        if off > tol:
            out.append(f"{a}: the drive got {off:.4g} mm or deg more or less than the component's correction pin says")
    if rb.stall_errors is not None and not any("following error" in e for e in rb.stall_errors):
        out.append(f"with the drives stalled (feedback frozen) and the joints commanded {STALL_STEP:g} mm or deg on, "
                   f"motion tripped no following error (errors: {rb.stall_errors}): its feedback is not the drive's")
    return out


def machine_run(m, folder: Path, q, joints: dict[str, int], kind: int, component: bool):
    """vecpin's LinuxCNC files in ``folder`` on the real controller, commanded to ``q``
    (N, n) [m, rad], joints numbered ``joints``: (commanded positions, COMP_FILE part, component
    part), each (N, n) in mm/deg, axes in the machine's order. Raises when the controller
    faulted or the feedback path is unsound (:func:`feedback_problems`, 1e-6 mm or deg)."""
    rb = machine_readback(m, folder, q, joints, kind, component)
    problems = feedback_problems(rb, 1e-6)
    if problems:
        raise RuntimeError("the feedback path is unsound:\n" + "\n".join(problems))
    return rb.pos, rb.pitch, rb.cross


def to_si(m, values_user):
    """(N, n) mm/deg -> m/rad, axes in the machine's order."""
    return np.column_stack([m.axes[k].to_si(values_user[:, k]) for k in range(len(m.axes))])

#!/usr/bin/python3
"""LinuxCNC's display in the tests' configurations (tests/linuxcnc_sim.py copies it as
driver.py; it runs in LinuxCNC's system Python, with its ``hal`` and ``linuxcnc`` modules).

Switches the machine on, homes it in place, and moves with ``G53 G1`` in MDI to each
command of ``commands.json``. After every move it checks the controller: its error
channel (a following error is reported there as "joint N following error"), the task
state (ON) and motion (enabled); a fault ends the run with the controller's messages.
At each command, at rest, it reads the HAL pins asked for and motion's following error
of every joint (``pos-cmd - pos-fb``, joint units; and its largest so far). Last, with ``stall`` given, it stalls
the drives (unlinks their feedback pins: a pin off its net keeps its last value, so the
feedback freezes as a jammed axis's encoder would) and moves every joint ``stall_step``
(mm or deg) further: motion must then trip a following error. Before each move it sets
the pins of ``setp`` (``halcmd setp``), at rest it reads those of ``getp`` (``halcmd
getp``). Writes ``result.json``."""
import json
import subprocess
import time

import hal
import linuxcnc

cfg = json.load(open("commands.json"))
probe = hal.component("vecpin-driver")  # hal.get_value needs a component of this process
probe.ready()
s, c, e = linuxcnc.stat(), linuxcnc.command(), linuxcnc.error_channel()
n = cfg["joints"]
out = {"error": None, "errors": [], "messages": [], "rows": [], "limits": None, "stall": None}


class Fault(Exception):
    """The controller reported an error or is no longer on."""


def drain():
    """The controller's errors since the last call (every message also goes to out["messages"])."""
    new = []
    while True:
        m = e.poll()
        if not m:
            out["errors"] += new
            return new
        kind, text = m
        out["messages"].append(text)
        if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            new.append(text)


def check(where, on=True):
    s.poll()
    new = drain()
    if new:
        raise Fault(f"{where}: " + "; ".join(new))
    if on and (s.task_state != linuxcnc.STATE_ON or not s.enabled):
        raise Fault(f"{where}: the machine is no longer on (task state {s.task_state}, motion enabled "
                    f"{bool(s.enabled)})")


def wait(cond, where, t=30.0):
    t0 = time.time()
    while time.time() - t0 < t:
        check(where, on=False)
        if cond():
            return
        time.sleep(0.01)
    raise Fault(f"{where}: timed out after {t:.0f} s")


def go(target, feed):
    c.mdi(f"G53 G1 F{feed} " + " ".join(f"{k}{v:.9f}" for k, v in zip(cfg["letters"], target)))
    return c.wait_complete(60)


try:
    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.state(linuxcnc.STATE_ON)
    wait(lambda: s.task_state == linuxcnc.STATE_ON, "switching on")
    c.home(-1)
    wait(lambda: all(s.homed[:n]), "homing")
    check("after homing")
    out["limits"] = [{k: s.joint[j][k] for k in ("min_ferror", "max_ferror")} for j in range(n)]
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    for k, cmd in enumerate(cfg["commands"]):
        for pin, value in ((cfg.get("setp") or [{}] * len(cfg["commands"]))[k]).items():   # e.g. a temperature
            subprocess.run(["halcmd", "setp", pin, repr(float(value))], check=True, capture_output=True)
        # fast to 0.01 short of the command on every joint, then creep to it: the COMP_FILE trim is
        # looked up while a joint moves (control.c), so the last step before the stop must be small
        for dq, feed in ((cfg["creep"], 1000000), (0.0, 6)):
            if go([v - dq for v in cmd], feed) == -1:
                raise Fault(f"moving to {cmd}: timed out")
            check(f"moving to {cmd}")
        wait(lambda: s.inpos and s.state == linuxcnc.RCS_DONE, f"settling at {cmd}", 120.0)  # a loaded machine is slow
        time.sleep(0.3)  # let the comp ramps (backlash_filt, the component's fade-in) settle
        check(f"at {cmd}")
        row = {p: hal.get_value(p) for p in cfg["pins"]}
        for pin in cfg.get("getp") or []:
            row[pin] = float(subprocess.run(["halcmd", "getp", pin], check=True, capture_output=True,
                                            text=True).stdout)
        row["ferror"] = [s.joint[j]["ferror_current"] for j in range(n)]
        row["ferror_highmark"] = [s.joint[j]["ferror_highmark"] for j in range(n)]
        out["rows"].append(row)
    if cfg["stall"]:
        for pin in cfg["stall"]:
            subprocess.run(["halcmd", "unlinkp", pin], check=True, capture_output=True)
        go([v + d for v, d in zip(cfg["commands"][-1], cfg["stall_step"])], 1000000)
        time.sleep(0.3)
        s.poll()
        out["stall"] = {"errors": drain(), "on": s.task_state == linuxcnc.STATE_ON and bool(s.enabled)}
except Exception as exc:
    out["error"] = str(exc) if isinstance(exc, Fault) else repr(exc)
    time.sleep(0.3)
    drain()                       # errors that reached the channel after the state changed
json.dump(out, open("result.json", "w"))
c.state(linuxcnc.STATE_OFF)

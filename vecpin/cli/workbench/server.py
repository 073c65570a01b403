"""The workbench's local web server (Flask, bound to 127.0.0.1): the page, the session
kept in FOLDER/session.json, and one job at a time: a stage's command line run as
``python -m vecpin ...`` in FOLDER, its output lines polled by the page, cancel ends it.

The page asks; this server only stores the choices, runs the commands ``vecpin run``
would run and hands back their files and the figures they wrote (mm)."""
from __future__ import annotations

import argparse
import io
import json
import multiprocessing
import multiprocessing.forkserver
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

from vecpin.cli.session import COMMAND, MANAGED, _subparser, stage_argv
from vecpin.errors import VecpinError
from vecpin.workflows.session import FORMAT, INPUT_FIELDS, OUTPUTS, SESSION_FILE, STAGES, VERSION, session_from_dict

STATIC = Path(__file__).with_name("static")
TEMPLATE = "profile_template.json"   # the profile template the profile stage's form is built from
PROFILE = "profile.json"             # the filled profile the form writes (the tables stage's input)
SCENE = "scene.html"                 # the meshcat scene page of the fit
KEPT_LINES = 400                     # output lines of a job the page is sent
INPUT_HELP = {"export": "the tracker software's export (a path; relative: from the day's folder)",
              "before": "the validation run without the tables, as a campaign CSV (empty: the one imported above)",
              "after": "the validation run with the tables, as a campaign CSV (empty: the one imported above)"}


def _kind(action: argparse.Action) -> str:
    """How the page asks for an option: a switch, a number, a list (repeated option, ';'
    between), several values (spaces between), a choice or a text."""
    if action.nargs == 0:
        return "switch"
    if isinstance(action, argparse._AppendAction):
        return "list"
    if action.nargs in ("+", "*") or (isinstance(action.nargs, int) and action.nargs > 1):
        return "several"
    if action.choices:
        return "choice"
    return {int: "int", float: "number"}.get(action.type, "text")


def _help(action: argparse.Action) -> str:
    try:
        return (action.help or "") % {"default": action.default, "prog": "", "choices": action.choices}
    except (KeyError, TypeError, ValueError):
        return action.help or ""


def stage_options(parser: argparse.ArgumentParser, stage: str) -> list[dict]:
    """The fields of ``stage``'s form, from its command's own argparse definitions: the
    files the user brings first (:data:`INPUT_FIELDS`), then every long option the session
    does not set itself, each with its kind, choices, default and help."""
    actions = {o[2:]: a for a in _subparser(parser, COMMAND[stage])._actions for o in a.option_strings
               if o.startswith("--") and a.dest != "help"}
    out = [{"name": k, "kind": "file", "help": _help(actions[k]) if k in actions else INPUT_HELP[k]}
           for k in INPUT_FIELDS.get(stage, ())]
    for name, a in actions.items():
        if name in MANAGED[stage] or name in INPUT_FIELDS.get(stage, ()):
            continue
        default = a.default if isinstance(a.default, (str, int, float, bool)) or a.default is None else None
        out.append({"name": name, "kind": _kind(a), "choices": list(a.choices) if a.choices else None,
                    "default": None if default == argparse.SUPPRESS else default, "help": _help(a),
                    "metavar": a.metavar if isinstance(a.metavar, str) else None,
                    "count": a.nargs if isinstance(a.nargs, int) and a.nargs > 1 else None})
    return out


#: what a stage's process has loaded before it is asked for (the forkserver's preload):
#: each stage then starts warm instead of importing these again
PRELOAD = ["vecpin.cli.main", "scipy.optimize", "scipy.linalg", "pinocchio", "vecpin.workflows.fitting",
           "vecpin.workflows.tables", "vecpin.workflows.planning", "vecpin.workflows.diagnosing", "vecpin.viz.figures",
           "vecpin.workflows.verifying", "vecpin.workflows.importing", "vecpin.workflows.assessing",
           "vecpin.workflows.evaluation", "vecpin.workflows.viewing"]
_CONTEXT = None


def _context():
    """The multiprocessing context the stages run in: processes forked from a server process
    that imported :data:`PRELOAD` once (started at the first stage, not before the page)."""
    global _CONTEXT
    if _CONTEXT is None:
        _CONTEXT = multiprocessing.get_context("forkserver")
        _CONTEXT.set_forkserver_preload(PRELOAD)
    return _CONTEXT


_WARMING = threading.Event()


def warm_stages() -> None:
    """Start the stages' warm process (:func:`_context`) in the background, once: called when
    the page has asked for its session, so that it loads beside a usable page, not before it."""
    if not _WARMING.is_set():
        _WARMING.set()
        _context()
        threading.Thread(target=multiprocessing.forkserver.ensure_running, daemon=True).start()


def _stage_process(entry, argv: list[str], cwd: str, log: str) -> None:
    """In the stage's own process: stdout and stderr (Python's and the libraries') into
    ``log``, the command line run by ``entry`` (vecpin's ``main``) in ``cwd``, its code the
    exit code."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    sys.stdout = open(1, "w", encoding="utf-8", errors="replace", buffering=1, closefd=False)
    sys.stderr = open(2, "w", encoding="utf-8", errors="replace", buffering=1, closefd=False)
    os.chdir(cwd)
    try:
        code = entry(argv)
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code or 0)


class Job:
    """One command line run in the day's folder (``vecpin ARGV``, by vecpin's ``main`` in a
    process of its own), its merged output read line by line."""

    def __init__(self, stage: str, argv: list[str], cwd: Path, log: Path, entry):
        self.stage, self.argv = stage, argv
        self.proc = _context().Process(target=_stage_process, args=(entry, argv, str(cwd), str(log)))
        log.unlink(missing_ok=True)
        self.proc.start()
        self.log = log
        self.lines: list[str] = []
        self.started = time.monotonic()
        self.ended: float | None = None
        self.cancelled = False
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        while not self.log.exists() and self.proc.is_alive():
            time.sleep(0.05)
        rest = ""
        with open(self.log, encoding="utf-8", errors="replace") if self.log.exists() else io.StringIO() as f:
            while True:
                alive = self.proc.is_alive()
                rest += f.read()
                *done, rest = rest.split("\n")
                self.lines += done
                if not alive:
                    break
                time.sleep(0.1)
        if rest:
            self.lines.append(rest)
        self.proc.join()
        self.ended = time.monotonic()

    @property
    def code(self) -> int | None:
        return self.proc.exitcode

    def cancel(self) -> None:
        if self.proc.is_alive():
            self.cancelled = True
            self.proc.terminate()

    def state(self) -> dict:
        running = self.ended is None
        errors = [ln for ln in self.lines if ln.startswith("vecpin: error:")]
        return {"stage": self.stage, "command": "vecpin " + " ".join(self.argv), "running": running,
                "code": None if running else self.code, "cancelled": self.cancelled,
                "elapsed_s": round((self.ended or time.monotonic()) - self.started, 1),
                "lines": self.lines[-KEPT_LINES:], "error": errors[-1] if errors else None}


class Workbench:
    """The day's folder: its session (kept as written, checked when a stage runs) and its job."""

    def __init__(self, folder: Path, parser):
        self.parser = parser   # vecpin's command-line parser: the stages' lines are checked by it
        self.folder = folder.resolve()
        self.folder.mkdir(parents=True, exist_ok=True)
        self.lock = threading.Lock()
        self.job: Job | None = None
        self.logs = Path(tempfile.mkdtemp(prefix="vecpin-workbench-"))   # the jobs' output, not in the day's folder
        self.load_error: str | None = None
        path = self.folder / SESSION_FILE
        self.raw = {"format": FORMAT, "version": VERSION, "machine": "", "tolerance_mm": None, "stages": {}}
        if path.exists():
            try:
                self.raw = json.loads(path.read_text(encoding="utf-8"))
                session_from_dict(self.raw, str(path), path)
            except (ValueError, VecpinError) as exc:
                self.load_error = str(exc)

    @property
    def path(self) -> Path:
        return self.folder / SESSION_FILE

    def session(self):
        return session_from_dict(self.raw, str(self.path), self.path)

    def save(self) -> None:
        from vecpin.fileio import write_text
        write_text(self.path, json.dumps(self.raw, indent=1) + "\n")

    def set_fields(self, stage: str, fields: dict) -> None:
        """Record a stage's choices (``machine``: the machine, the tolerance and the options set
        once for the day) and save."""
        if stage == "machine":   # the options set once for the day go to the session's machine_options
            machine, tol = fields.get("machine") or "", fields.get("tolerance_mm")
            if not isinstance(machine, str):
                raise VecpinError(f"machine: {machine!r}: a bundled machine name or a URDF path")
            if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < 1e300):
                raise VecpinError(f"tolerance_mm: {tol!r}: a length in mm > 0, or empty (not stated)")
            shared = {k: v for k, v in fields.items() if k not in ("machine", "tolerance_mm") and v not in (None, "")}
            head = {"format": self.raw.get("format"), "version": self.raw.get("version"),
                    "machine": machine.strip(), "tolerance_mm": tol}
            rest = {k: v for k, v in self.raw.items() if k not in head and k != "machine_options"}
            self.raw = head | ({"machine_options": shared} if shared else {}) | rest
        else:
            if stage not in STAGES:
                raise KeyError(stage)
            stages = self.raw.setdefault("stages", {})
            stages[stage] = {k: v for k, v in fields.items() if v is not None and v != ""}
            self.raw["stages"] = {s: stages[s] for s in STAGES if s in stages}
        self.save()

    def argv(self, stage: str) -> list[str]:
        """The command line of ``stage``; the views that are not session stages: the machine's
        info, the controller's profile template, the scene page."""
        session = self.session()
        if stage == "machine":
            return ["info", session.machine_argument()]
        if stage == "profile":
            controller = session.stages.get("tables", {}).get("controller") or "generic"
            (self.folder / TEMPLATE).unlink(missing_ok=True)   # the template is the workbench's own file
            return ["profile", session.machine_argument(), "--controller", controller, "--out", TEMPLATE]
        if stage == "scene":
            return ["view", OUTPUTS["fit"], OUTPUTS["import"], "--html", SCENE]
        return stage_argv(session, stage, self.parser)

    def start(self, stage: str) -> dict:
        with self.lock:
            if self.job and self.job.ended is None:
                raise VecpinError(f"the stage {self.job.stage} is still running: wait for it or cancel it")
            entry = self.parser.get_default("entry")   # vecpin's main, as ``vecpin run`` calls it
            self.job = Job(stage, self.argv(stage), self.folder, self.logs / "job.log", entry)
            return self.job.state()

    def state(self) -> dict:
        from vecpin.workflows.record import stage_figures
        tol = self.raw.get("tolerance_mm") if isinstance(self.raw.get("tolerance_mm"), (int, float)) else None
        done = {s: (self.folder / OUTPUTS[s]).exists() for s in STAGES}
        done.update(scene=(self.folder / SCENE).exists(), profile=(self.folder / PROFILE).exists(),
                    report=(self.folder / "record.md").exists())
        return {"folder": str(self.folder), "session": self.raw, "load_error": self.load_error, "done": done,
                "figures": stage_figures(self.folder, tol), "job": self.job.state() if self.job else None}


def create_app(folder: Path, parser):
    """The Flask application of the workbench in ``folder``; ``parser``: vecpin's."""
    from flask import Flask, jsonify, request, send_from_directory

    bench = Workbench(folder, parser)
    app = Flask(__name__, static_folder=str(STATIC), static_url_path="/static")
    app.json.sort_keys = False   # the axes and stages in their own order
    app.config["bench"] = bench

    def fail(exc: Exception, status: int = 400):
        return jsonify({"error": str(exc)}), status

    def body(key: str, default=None) -> dict:
        """The request's JSON object's ``key``, itself an object (a page of another shape is refused)."""
        d = request.get_json(force=True)
        value = d.get(key, default) if isinstance(d, dict) else None
        if not isinstance(value, dict):
            raise VecpinError(f"the request is a JSON object whose '{key}' is an object, not {value!r}")
        return value

    @app.before_request
    def only_this_page():
        """Nothing but this computer's own page: the address it was asked at must be the
        local one (no other name resolving to it), and a change must carry the page's own
        header, which another site's page cannot send without asking first."""
        host = (request.host or "").rsplit(":", 1)[0]
        if host not in ("127.0.0.1", "localhost"):
            return jsonify({"error": f"the workbench answers at 127.0.0.1 only, not {host!r}"}), 403
        if request.method == "POST" and request.headers.get("X-Vecpin-Workbench") != "1":
            return jsonify({"error": "a change must come from the workbench's own page"}), 403
        return None

    @app.get("/")
    def index():
        return send_from_directory(STATIC, "index.html")

    @app.get("/api/state")
    def state():
        answer = jsonify(bench.state())
        if app.config.get("WARM_STAGES"):   # set by serve(): the page's last call before it is usable
            warm_stages()
        return answer

    @app.get("/api/choices")
    def choices():
        from vecpin.export.names import CONTROLLERS
        from vecpin.kinematics.bundled import bundled_machines   # no Pinocchio before the page
        return jsonify({"machines": bundled_machines(), "controllers": list(CONTROLLERS), "stages": list(STAGES)})

    @app.get("/api/options")
    def options():
        return jsonify({s: stage_options(bench.parser, s) for s in STAGES})

    @app.post("/api/stage/<stage>")
    def set_stage(stage):
        try:
            bench.set_fields(stage, body("fields", {}))
            argv = bench.argv(stage) if stage in STAGES else None
        except KeyError:
            return fail(KeyError(f"no stage {stage}"), 404)
        except VecpinError as exc:
            return fail(exc)
        return jsonify({"ok": True, "command": "vecpin " + " ".join(argv) if argv else None})

    @app.post("/api/run/<stage>")
    def run(stage):
        if stage not in STAGES + ("machine", "profile", "scene"):
            return fail(KeyError(f"no stage {stage}"), 404)
        try:
            return jsonify(bench.start(stage))
        except VecpinError as exc:
            return fail(exc)

    @app.post("/api/cancel")
    def cancel():
        if bench.job:
            bench.job.cancel()
        return jsonify({"ok": True})

    @app.get("/api/profile")
    def profile():
        out = {}
        for key, name in (("template", TEMPLATE), ("profile", PROFILE)):
            p = bench.folder / name
            out[key] = json.loads(p.read_text(encoding="utf-8")) if p.is_file() else None
        return jsonify(out)

    @app.post("/api/profile")
    def save_profile():
        from vecpin.fileio import write_text
        try:
            profile = body("profile")
        except VecpinError as exc:
            return fail(exc)
        write_text(bench.folder / PROFILE, json.dumps(profile, indent=1) + "\n")
        fields = dict(bench.raw.get("stages", {}).get("tables", {}), profile=PROFILE)
        bench.set_fields("tables", fields)
        return jsonify({"ok": True})

    @app.post("/api/record")
    def write_record_():
        from vecpin.cli.session import session_commands
        from vecpin.workflows.record import write_record
        try:
            session = bench.session()
            commands = session_commands(session, bench.parser)
            written = write_record(session, bench.folder, {s: c for s, c in commands.items()
                                                           if (bench.folder / OUTPUTS[s]).exists()})
        except VecpinError as exc:
            return fail(exc)
        return jsonify({"ok": True, "written": [p.name for p in written]})

    @app.get("/files/<path:name>")
    def files(name):
        if not (bench.folder / name).resolve().is_relative_to(bench.folder):   # a link that leaves the day's folder
            return fail(FileNotFoundError(f"{name}: not a file of the day's folder"), 404)
        return send_from_directory(bench.folder, name, max_age=0)

    return app


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def serve(folder: Path, parser, port: int = 8745, open_browser: bool = True) -> int:
    """Serve the workbench of ``folder`` on 127.0.0.1 until Ctrl-C; prints its address.
    ``parser``: vecpin's command-line parser."""
    from werkzeug.serving import make_server
    app = create_app(folder, parser)
    app.config["WARM_STAGES"] = True
    server = make_server("127.0.0.1", port, app, threaded=True)
    url = f"http://127.0.0.1:{server.server_port}/"
    print(f"vecpin workbench of {Path(folder).resolve()}: {url} (Ctrl-C stops it)", flush=True)
    if open_browser:
        import webbrowser
        webbrowser.open(url)
    signal.signal(signal.SIGTERM, _interrupt)   # a terminated workbench ends as Ctrl-C ends it
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        bench = server.app.config["bench"]
        if bench.job:
            bench.job.cancel()
            bench.job.reader.join(timeout=10)
        # the stages' warm process ends with the workbench (multiprocessing has no public stop)
        getattr(multiprocessing.forkserver._forkserver, "_stop", lambda: None)()
        shutil.rmtree(bench.logs, ignore_errors=True)
    return 0

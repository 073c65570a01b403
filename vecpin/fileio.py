"""Writing files so that an interrupted run never leaves a half-written or mixed result.

Every file vecpin writes goes through :func:`write_text` / :func:`write_bytes`: the data
go to a temporary file in the same folder, which is flushed, synced and renamed over the
target (``os.replace`` is atomic on one file system). A result of several files (a
diagnosis, a table set, a simulation) is written with :class:`OutputSet`: every file is
staged first and renamed into place only once all of them are complete, so an
interruption leaves either the old set or the new one, never a half-written set. Files
of an earlier run that the new set does not write stay where they are, unless the set
keeps a *manifest* (see :class:`OutputSet`). :func:`check_output_dir` / :func:`check_output_file` test a path
before the work starts (by creating and removing a temporary file there: permissions
alone do not tell root or a read-only file system), so a typo does not cost a long
computation. A set's file names are data, never paths: a name that would leave the
output folder (``..``, absolute, a drive) is refused (:func:`inside_name`) before anything
is written, whatever a URDF or a profile calls its axes.

Every set ends with one generation: :data:`MANIFEST` (``vecpin-manifest.json``) lists the
files the set wrote (name, bytes, SHA-256), the command, the time and a generation id. It is
written twice: before the first rename with ``"complete": false`` and after the last with
``"complete": true``, so an interruption between them leaves a manifest that says the folder
is mixed and tells the new files (those whose SHA-256 it lists) from the old ones. No file
of a set is written through a symbolic link that leaves the output folder, and no two
names of a set differ only by case (they would be one file on a case-insensitive file
system or controller).
"""
from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import uuid
from pathlib import Path

from vecpin.errors import OutputError

MANIFEST = "vecpin-manifest.json"   # the generation of the last set written in a folder
_COMMAND: list[str] | None = None   # the command line the results come from (set by the command line)


def set_command(words: list[str] | None) -> None:
    """The command the manifests record (the command line sets it; else ``sys.argv``)."""
    global _COMMAND
    _COMMAND = None if words is None else [str(w) for w in words]


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file + rename)."""
    path = Path(path)
    _parent_ok(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise _cannot(path, exc) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600: give the file the user's usual mode
        os.replace(tmp, path)
    except BaseException as exc:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _cannot(path, exc) from None
        raise
    return path


def _cannot(path, exc: OSError) -> OutputError:
    """An operating-system refusal to write (read-only or special file system, disk full, ...)."""
    return OutputError(f"{path}: cannot be written ({exc.strerror or exc}); give a path you can write to")


def _read_umask() -> int:
    """The process umask, without changing it where the system tells it (Linux
    ``/proc/self/status``, kernel 4.7+); elsewhere by setting and restoring it, which is
    done once, at import, before vecpin starts any thread."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# The umask at import: files get the mode a plain open() would give them (0o666 & ~umask).
# Reading it per write would set the umask of every thread for a moment.
_UMASK = _read_umask()


def write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically; line ends are written as given."""
    return write_bytes(path, text.encode("utf-8"))


def _parent_ok(path: Path) -> None:
    parent = path.parent
    if not parent.exists():
        raise OutputError(f"{path}: the folder {parent} does not exist; create it first or give another path")
    if not parent.is_dir():
        raise OutputError(f"{path}: {parent} is a file, not a folder; give a path in a folder")
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; give a file name")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"{path}: no permission to write in {parent}; give a folder you can write in")


def check_output_file(path: str | Path, option: str = "out") -> Path:
    """Fail now, naming the parameter ``option``, if a file cannot be written at ``path``: also
    where something that is not a regular file stands there (a device such as /dev/null, a
    folder, a pipe), which the atomic write would replace."""
    path = Path(path)
    if path.exists() or path.is_symlink():
        if path.is_dir():
            raise OutputError(f"`{option}` {path}: a folder; give the path of a file")
        if not path.is_file():
            raise OutputError(f"`{option}` {path}: not a regular file (a device, a pipe or a socket), which writing "
                              "would replace; give the path of a file")
    try:
        _parent_ok(path)
        _probe(path.parent)
    except OutputError as exc:
        raise OutputError(f"`{option}` {exc}") from None
    return path


def _probe(folder: Path) -> None:
    """Create and remove a temporary file in ``folder``: the only test that holds for
    every user (root included) and every file system (read-only mounts, /proc)."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise _cannot(folder, exc) from None


def check_output_dir(path: str | Path, option: str = "out_dir") -> Path:
    """Fail now, naming the parameter ``option``, if ``path`` cannot become an output folder
    (a file in the way, no permission); the folder itself is created when the results are written."""
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise OutputError(f"`{option}` {path}: a symbolic link to nothing ({os.readlink(path)}); give a folder")
    p = path
    while not p.exists():
        p = p.parent
    if not p.is_dir():
        raise OutputError(f"`{option}` {path}: {p} is a file, not a folder; give another output folder")
    if not os.access(p, os.W_OK):
        raise OutputError(f"`{option}` {path}: no permission to write in {p}; give a folder you can write in")
    try:
        _probe(p)
    except OutputError as exc:
        raise OutputError(f"`{option}` {path}: {exc}") from None
    return path


class OutputSet:
    """Files of one result, committed together.

    >>> with OutputSet(out_dir) as out:          # doctest: +SKIP
    ...     out.write_text("a.json", text)
    ...     p = out.path("figure.png"); fig.savefig(p)   # any writer, into the staging folder
    Nothing appears in ``out_dir`` until the block ends without an exception; then each
    staged file is renamed into place. ``final(name)`` is where a file will end up.

    Files already in ``out_dir`` that the set does not write are left alone, except with
    ``manifest="NAME"`` (a command that owns its folder, e.g. ``tables``): the set then
    records its files and their SHA-256 in ``.vecpin-NAME.manifest``, and removes the
    files the previous manifest of the same NAME lists that this set no longer writes
    (a former controller's files), but only those still unchanged since that run wrote
    them; a file a user added or edited is never removed. ``removed``: what went.
    """

    def __init__(self, out_dir: str | Path, manifest: str | None = None):
        self.dir = Path(out_dir)
        check_output_dir(self.dir)
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            self._stage = Path(tempfile.mkdtemp(prefix=".vecpin-staging-", dir=self.dir))
        except OSError as exc:
            raise OutputError(f"`out_dir` {self.dir}: cannot be written ({exc.strerror or exc}); give a folder you can "
                              "write in") from None
        self.written: list[Path] = []
        self.kind = manifest
        self.manifest = None if manifest is None else f".vecpin-{manifest}.manifest"
        self.removed: list[Path] = []

    def path(self, name: str) -> Path:
        """A staging path for ``name`` (relative, may contain a subfolder). A name that
        would leave the output folder (absolute, ``..``, a drive) is an OutputError: no
        file of a set is ever written outside ``out_dir``, whatever names it is given."""
        p = self._stage / inside_name(name, self.dir)
        if name == MANIFEST:
            raise OutputError(f"output file name {name!r}: the name of the manifest vecpin writes last in every output "
                              "folder; give the file another name")
        same = [q for q in self.written if q != p and str(q).casefold() == str(p).casefold()]
        if same:
            raise OutputError(f"output file names {same[0].relative_to(self._stage).as_posix()!r} and {name!r} differ "
                              f"only by case: one file on a case-insensitive file system or controller; nothing was "
                              f"written in {self.dir}")
        p.parent.mkdir(parents=True, exist_ok=True)
        if p not in self.written:
            self.written.append(p)
        return p

    def final(self, name: str) -> Path:
        return self.dir / inside_name(name, self.dir)

    def write_text(self, name: str, text: str) -> Path:
        p = self.path(name)
        p.write_text(text, encoding="utf-8")
        return self.final(name)

    def write_bytes(self, name: str, data: bytes) -> Path:
        p = self.path(name)
        p.write_bytes(data)
        return self.final(name)

    def __enter__(self) -> "OutputSet":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                for p in self.written:
                    if p.exists():
                        with open(p, "rb") as fh:
                            os.fsync(fh.fileno())
                staged = [p for p in self.written if p.exists()]
                digests = {p.relative_to(self._stage).as_posix(): _sha256(p) for p in staged}
                self._check_links(list(digests))
                generation = self._generation(digests, complete=False)   # the folder is mixed from here ...
                for p in staged:
                    target = self.dir / p.relative_to(self._stage)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(p, target)
                generation["complete"] = True                            # ... to here
                write_text(self.dir / MANIFEST, json.dumps(generation, indent=1) + "\n")
                if self.manifest:
                    self._remove_stale(digests)
                    write_text(self.dir / self.manifest, f"# files vecpin {self.kind} wrote here: sha256, "
                               "name; the next run removes those it no longer writes, if unchanged\n"
                               + "".join(f"{h}  {n}\n" for n, h in sorted(digests.items())))
        except OSError as err:  # not exc: that names the exception the block raised
            raise _cannot(self.dir, err) from None
        finally:
            _remove_tree(self._stage)
        return False


    def _generation(self, digests: dict[str, str], complete: bool) -> dict:
        """The manifest of this set (written now with ``complete`` false): files with bytes and
        SHA-256, the command, the UTC time, a new generation id and the one it follows."""
        old, prev = None, self.dir / MANIFEST
        try:   # a regular file of a manifest's size only (not a link to a device)
            if prev.is_file() and not prev.is_symlink() and prev.stat().st_size < 50_000_000:
                old = json.loads(prev.read_text(encoding="utf-8")).get("generation")
        except (OSError, ValueError, AttributeError):
            pass
        d = {"format": "vecpin-manifest", "generation": uuid.uuid4().hex, "previous": old, "complete": complete,
             "command": _COMMAND if _COMMAND is not None else list(sys.argv),
             "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
             "meaning": "the files of one result, committed together; complete false: the run stopped while "
                        "putting them in place, and the files whose sha256 differs are an earlier run's",
             "files": [{"name": n, "bytes": (self._stage / n).stat().st_size, "sha256": h}
                       for n, h in sorted(digests.items())]}
        write_text(self.dir / MANIFEST, json.dumps(d, indent=1) + "\n")
        return d

    def _check_links(self, names: list[str]) -> None:
        """Refuse (before anything is renamed) a name whose path in the output folder passes
        through a symbolic link that leads out of it: the file would be written there."""
        root = self.dir.resolve()
        for name in names:
            cur = self.dir
            for part in Path(name).parts:
                cur = cur / part
                if not cur.is_symlink():
                    continue
                dest = cur.resolve()
                if dest != root and root not in dest.parents:
                    raise OutputError(f"`out_dir` {self.dir}: {cur} is a symbolic link to {dest}, outside the output "
                                      f"folder, and {name} would be written through it; nothing was written: remove "
                                      "the link or give another folder")

    def _remove_stale(self, keep: dict[str, str]) -> None:
        """Remove the files the previous manifest lists, that this set does not write and
        that are unchanged since (same SHA-256); names that leave the folder are ignored."""
        old = self.dir / self.manifest
        if not old.is_file():
            return
        root = self.dir.resolve()
        for line in old.read_text(encoding="utf-8", errors="replace").splitlines():
            digest, _, name = line.partition("  ")
            if line.startswith("#") or not name or name in keep:
                continue
            target = (self.dir / name).resolve()
            if root not in target.parents or not target.is_file() or _sha256(target) != digest:
                continue
            target.unlink()
            self.removed.append(self.dir / name)
            parent = target.parent
            while parent != root and not any(parent.iterdir()):  # a subfolder the earlier run made, now empty
                parent.rmdir()
                parent = parent.parent


def inside_name(name: str, folder: str | Path) -> str:
    """``name`` if it is a relative path that stays inside ``folder`` (subfolders allowed;
    no ``..``, no absolute path, no drive, no control character); else an OutputError
    naming the name and the folder."""
    text = str(name)
    parts = text.replace("\\", "/").split("/")
    bad = (not text or text.startswith(("/", "\\")) or any(p in ("", ".", "..") for p in parts)
           or ":" in text or not text.isprintable())
    if not bad:
        root = Path(os.path.abspath(folder))
        bad = root not in Path(os.path.abspath(root / text)).parents
    if bad:
        raise OutputError(f"output file name {text!r} would not stay in the output folder {folder}: vecpin writes only "
                          "inside the folder it is given (a name from the URDF or the controller profile may not "
                          "be a path)")
    return text


def _sha256(p: Path) -> str:
    import hashlib
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


def _remove_tree(p: Path) -> None:
    if not p.exists():
        return
    for child in sorted(p.rglob("*"), key=lambda c: -len(c.parts)):
        child.rmdir() if child.is_dir() else child.unlink()
    p.rmdir()

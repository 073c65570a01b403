"""vecpin.fileio: files get the mode the user's umask gives a plain open(), and writing
never changes the process umask (which other threads share)."""
import os
import stat
import subprocess
import sys
import textwrap

import pytest

from vecpin import fileio

SCRIPT = textwrap.dedent("""
    import os, stat, sys
    os.umask(int(sys.argv[1], 8))
    from vecpin.fileio import OutputSet, write_text
    d = sys.argv[2]
    write_text(os.path.join(d, "vecpin.txt"), "x")
    with OutputSet(os.path.join(d, "set")) as out:
        out.write_text("a.txt", "a")
    with open(os.path.join(d, "plain.txt"), "w") as fh:   # the reference: what open() gives
        fh.write("x")
    modes = [stat.S_IMODE(os.stat(os.path.join(d, p)).st_mode) for p in ("vecpin.txt", "set/a.txt", "plain.txt")]
    print(" ".join(oct(m) for m in modes), oct(os.umask(0)))
""")


@pytest.mark.skipif(os.name != "posix", reason="POSIX file modes")
@pytest.mark.parametrize("mask", ["027", "002", "077"])
def test_files_get_the_mode_open_gives_under_the_users_umask(tmp_path, mask):
    out = subprocess.run([sys.executable, "-c", SCRIPT, mask, str(tmp_path)], capture_output=True, text=True, check=True)
    vecpin_mode, set_mode, plain_mode, umask_after = out.stdout.split()
    assert vecpin_mode == plain_mode == set_mode == oct(0o666 & ~int(mask, 8))
    assert umask_after == oct(int(mask, 8))  # and the umask is the user's still


def test_writing_never_touches_the_umask(tmp_path, monkeypatch):
    def forbidden(mask):
        raise AssertionError("os.umask called while writing: it changes the mask of every thread")
    monkeypatch.setattr(os, "umask", forbidden)
    p = fileio.write_text(tmp_path / "a.txt", "hello")
    assert p.read_text() == "hello"
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~fileio._UMASK


def test_umask_read_without_proc_falls_back_to_set_and_restore(monkeypatch):
    current = os.umask(0o022)
    os.umask(current)

    def no_proc(*a, **k):
        raise OSError("no /proc")
    monkeypatch.setattr(fileio, "open", no_proc, raising=False)
    assert fileio._read_umask() == current
    after = os.umask(0o022)
    os.umask(after)
    assert after == current


def test_an_output_file_never_replaces_a_device_or_a_folder(tmp_path):
    """Issue 42: `--out /dev/null` (as root) replaced the system's /dev/null with a file. A
    device, a pipe or a folder where an output file should go is refused, naming the option."""
    import os
    import pytest
    from vecpin.errors import OutputError
    from vecpin.fileio import check_output_file
    with pytest.raises(OutputError, match="`out` /dev/null: not a regular file"):
        check_output_file("/dev/null")
    os.mkfifo(tmp_path / "pipe")
    with pytest.raises(OutputError, match="not a regular file"):
        check_output_file(tmp_path / "pipe")
    with pytest.raises(OutputError, match="a folder"):
        check_output_file(tmp_path)
    assert check_output_file(tmp_path / "model.json") == tmp_path / "model.json"
    (tmp_path / "old.json").write_text("{}")
    assert check_output_file(tmp_path / "old.json") == tmp_path / "old.json"   # a file is replaced, as before

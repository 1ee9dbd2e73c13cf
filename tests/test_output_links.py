"""No write outside OUT: links and other files planted where torlab writes.

Whoever can write the folder above OUT can put a symbolic link (or a hard link, a FIFO) at
any name torlab is about to use there: the lock file ``.OUT.lock``, OUT itself, the staging
folder.  Every one of those names is opened relative to its folder without following a
link (:mod:`torlab.outputs`), so the link is refused with one line and exit 2 and the file
it points to is never opened for writing.  Each test checks the victim's bytes (and mode)
afterwards, not torlab's message alone.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from conftest import ROOT, error_lines

from torlab.errors import OutputWriteError

HPT_LOG = ROOT / "sample_data" / "hpt" / "hpt_OFM1_4uL_25C.txt"


def _victim(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    v = folder / "victim.txt"
    v.write_text("precious\n")
    v.chmod(0o640)
    return v


def _intact(v: Path) -> bool:
    return v.read_text() == "precious\n" and stat.S_IMODE(v.stat().st_mode) == 0o640


def test_planted_lock_link_is_refused_and_the_victim_untouched(cli, tmp_path):
    # the reported case: mkdir X; echo precious > X/victim.txt; ln -s victim.txt X/.out.lock
    x = tmp_path / "X"
    victim = _victim(x)
    (x / ".out.lock").symlink_to("victim.txt")
    r = cli("hpt", "reduce", HPT_LOG, "-o", x / "out")
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert line.startswith(f"error: {x / 'out'}: the lock file ") and "symbolic link" in line
    assert _intact(victim)
    assert sorted(p.name for p in x.iterdir()) == [".out.lock", "victim.txt"]  # nothing made


@pytest.mark.parametrize("kind", ["dangling", "absolute", "hard", "fifo"])
def test_other_planted_lock_files_are_refused(tmp_path, kind):
    from torlab.outputs import OutputDir

    x = tmp_path / "X"
    victim = _victim(tmp_path / "elsewhere")
    lock = x / ".out.lock"
    x.mkdir()
    if kind == "dangling":  # would create a file wherever the link points
        lock.symlink_to(tmp_path / "elsewhere" / "new.txt")
    elif kind == "absolute":
        lock.symlink_to(victim)
    elif kind == "hard":
        os.link(victim, lock)
    else:
        os.mkfifo(lock)
    with pytest.raises(OutputWriteError, match="lock file") as e:
        OutputDir(x / "out")
    assert "symbolic link" in str(e.value) or "not a plain file" in str(e.value)
    assert _intact(victim)
    assert not (tmp_path / "elsewhere" / "new.txt").exists()


def test_output_folder_that_is_a_link_is_refused(cli, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    victim = _victim(elsewhere)
    (tmp_path / "out").symlink_to(elsewhere, target_is_directory=True)
    r = cli("hpt", "reduce", HPT_LOG, "-o", tmp_path / "out", "--force")
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert "is a symbolic link" in line and "give the folder it points to" in line
    assert sorted(p.name for p in elsewhere.iterdir()) == ["victim.txt"] and _intact(victim)
    # the folders above OUT may be links: they are the user's own path
    (tmp_path / "via").symlink_to(tmp_path / "real", target_is_directory=True)
    (tmp_path / "real").mkdir()
    assert cli("hpt", "reduce", HPT_LOG, "-o", tmp_path / "via" / "out").exit_code == 0
    assert (tmp_path / "real" / "out" / "summary.csv").is_file()


def test_staging_folder_swapped_for_a_link_is_never_written_through(tmp_path):
    from torlab.outputs import OutputDir

    elsewhere = tmp_path / "elsewhere"
    victim = _victim(elsewhere)
    d = OutputDir(tmp_path / "out")
    d.write_text("a.txt", "1")
    staging = d.staging
    os.rename(staging, tmp_path / "moved")       # someone renames the staging folder away
    staging.symlink_to(elsewhere, target_is_directory=True)  # and plants a link in its place
    d.write_text("victim.txt", "overwritten")    # goes to the run's own folder, not the link
    d.write_text("sub/b.txt", "2")
    assert _intact(victim) and sorted(p.name for p in elsewhere.iterdir()) == ["victim.txt"]
    with pytest.raises(OutputWriteError, match="moved or replaced"):
        d.path("c.txt")                          # a path for a caller's own writer: refused
    with pytest.raises(OutputWriteError, match="moved or replaced"):
        d.commit()
    assert _intact(victim) and not (tmp_path / "out").exists()
    assert staging.is_symlink()                  # the planted link is not followed to delete


def test_a_link_planted_inside_a_result_subfolder_name_is_refused(tmp_path):
    """Sub-folders of the results are made and entered without following links."""
    from torlab.outputs import OutputDir

    elsewhere = tmp_path / "elsewhere"
    victim = _victim(elsewhere)
    d = OutputDir(tmp_path / "out")
    (d.staging / "data").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(OutputWriteError):
        d.write_text("data/victim.txt", "overwritten")
    with pytest.raises(OutputWriteError):
        d.path("data/x.csv")
    d.abort()
    assert _intact(victim)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                    reason="needs root to give a folder to another user")
def test_leftovers_of_another_user_are_neither_restored_nor_deleted(tmp_path):
    from torlab.outputs import OutputDir

    old = tmp_path / ".out.old-1-2"
    old.mkdir()
    (old / "torlab-manifest.json").write_text('{"files": ["a.txt"]}\n')
    (old / "a.txt").write_text("planted")
    stale = tmp_path / ".out.staging-1-x"
    stale.mkdir()
    for p in (old, old / "a.txt", old / "torlab-manifest.json", stale):
        os.chown(p, 65534, 65534)
    with OutputDir(tmp_path / "out") as d:
        d.write_text("b.txt", "mine")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["b.txt",
                                                                     "torlab-manifest.json"]
    assert (old / "a.txt").read_text() == "planted" and stale.is_dir()


def test_lock_of_a_finished_run_is_removed_but_a_lock_put_in_its_place_is_not(tmp_path):
    from torlab.outputs import OutputDir

    d = OutputDir(tmp_path / "out")
    lock = tmp_path / ".out.lock"
    os.replace(lock, tmp_path / "held")          # someone else's lock file takes its name
    lock.write_text("other\n")
    d.abort()
    assert lock.read_text() == "other\n"


# ------------------------------------------------------------------ the folder's own mode
def test_force_never_replaces_a_read_only_output_folder(cli, tmp_path):
    out = tmp_path / "out"
    assert cli("hpt", "reduce", HPT_LOG, "-o", out, "--no-plot").exit_code == 0
    before = sorted(p.name for p in out.iterdir())
    out.chmod(0o555)
    try:
        r = cli("hpt", "reduce", HPT_LOG, "-o", out, "--force", "--no-plot")
        assert r.exit_code == 2
        (line,) = error_lines(r)
        assert line == (f"error: {out}: the output folder is read-only (mode 0555); make it "
                        "writable (chmod u+w) or choose another -o")
        assert sorted(p.name for p in out.iterdir()) == before
        assert stat.S_IMODE(out.stat().st_mode) == 0o555
    finally:
        out.chmod(0o755)


@pytest.mark.parametrize("umask", [0o022, 0o027, 0o077])
def test_results_get_the_umask_or_the_mode_of_the_folder_they_replace(tmp_path, umask):
    from torlab.outputs import OutputDir

    old = os.umask(umask)
    try:
        with OutputDir(tmp_path / "new") as d:
            d.write_text("sub/a.txt", "1")
        assert stat.S_IMODE((tmp_path / "new").stat().st_mode) == 0o777 & ~umask
        assert stat.S_IMODE((tmp_path / "new" / "sub").stat().st_mode) == 0o777 & ~umask
        assert stat.S_IMODE((tmp_path / "new" / "sub" / "a.txt").stat().st_mode) == \
            0o666 & ~umask
        mine = tmp_path / "mine"
        mine.mkdir()
        mine.chmod(0o751)  # a folder the user made beforehand keeps its mode
        with OutputDir(mine) as d:
            d.write_text("a.txt", "1")
        assert stat.S_IMODE(mine.stat().st_mode) == 0o751
        with OutputDir(mine, force=True) as d:  # and so do results replacing results
            d.write_text("a.txt", "2")
        assert stat.S_IMODE(mine.stat().st_mode) == 0o751
    finally:
        os.umask(old)

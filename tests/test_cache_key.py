"""The protocol cache's key is used only when it can be trusted.

The key signs ``OUT/.cache``: whoever knows it can put numbers into a re-run.  A key others
can read (a shared home folder, a copied key), a link to someone's file, a key of zeros, a
damaged key, a FIFO in its place, a relative configuration folder: each is refused with one
warning naming the key file, and the run uses a key of its own (nothing reused across runs,
the documented fallback) -- never the key, never a hang.  The test of each case is an entry
signed by someone who knows that key: it must be recomputed.
"""

from __future__ import annotations

import os
import threading
import warnings
from pathlib import Path

import pytest

from torlab.errors import TorlabWarning

KEY = "3f" * 8 + "".join(f"{i:02x}" for i in range(24))  # 32 bytes, 25 distinct values


def _store_with(folder: Path, cache_dir: Path, key_hex: str, monkeypatch) -> None:
    """Someone who knows ``key_hex`` signs an entry ``x`` (value 666) into ``cache_dir``."""
    from torlab.protocols.cache import ResultCache

    folder.mkdir(mode=0o700)
    (folder / "cache-key").write_text(key_hex + "\n")
    (folder / "cache-key").chmod(0o600)
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(folder))
    c = ResultCache(cache_dir)
    c.store("x", {"v": 666.0}, n=1)
    assert c.persistent_key


def _victim(config: Path, cache_dir: Path, monkeypatch) -> tuple[object, list[str]]:
    from torlab.protocols.cache import ResultCache

    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(config))
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        c = ResultCache(cache_dir)
        v = c.get_or_compute("x", lambda: {"v": 1.0}, n=1)
    return (c, v), [str(w.message) for w in got if issubclass(w.category, TorlabWarning)]


def _make(kind: str, key_file: Path, tmp_path: Path) -> None:
    key_file.parent.mkdir(mode=0o700, exist_ok=True)
    if kind == "readable":
        key_file.write_text(KEY + "\n")
        key_file.chmod(0o644)
    elif kind == "link":
        public = tmp_path / "public-key"
        public.write_text(KEY + "\n")
        public.chmod(0o644)
        key_file.symlink_to(public)
    elif kind == "zeros":
        key_file.write_text("00" * 32 + "\n")
        key_file.chmod(0o600)
    elif kind == "empty":
        key_file.write_text("")
        key_file.chmod(0o600)
    elif kind == "garbage":
        key_file.write_bytes(b"\xff\xfegarbage")
        key_file.chmod(0o600)
    elif kind == "short":
        key_file.write_text(KEY[:40] + "\n")
        key_file.chmod(0o600)
    elif kind == "folder":
        key_file.mkdir()
    elif kind == "dangling":
        key_file.symlink_to(tmp_path / "nowhere")
    elif kind == "fifo":
        os.mkfifo(key_file)
    elif kind == "open_folder":
        key_file.write_text(KEY + "\n")
        key_file.chmod(0o600)
        key_file.parent.chmod(0o777)


@pytest.mark.parametrize("kind, fragment", [
    ("readable", "can be read or written by others (mode 0644"),
    ("link", "is a symbolic link"),
    ("zeros", "is not random"),
    ("empty", "is damaged (empty)"),
    ("garbage", "is damaged"),
    ("short", "is damaged (not 64 hexadecimal digits)"),
    ("folder", "is a folder"),
    ("dangling", "is a symbolic link"),
    ("fifo", "not a regular file"),
    ("open_folder", "folder can be written by others"),
])
def test_a_key_that_cannot_be_trusted_is_not_used(tmp_path, monkeypatch, kind, fragment):
    from torlab.protocols import cache

    cache_dir = tmp_path / "out" / ".cache"
    _store_with(tmp_path / "mallory", cache_dir, KEY, monkeypatch)  # knows the key
    config = tmp_path / "victim"
    _make(kind, config / "cache-key", tmp_path)
    done: dict = {}
    t = threading.Thread(target=lambda: done.update(r=_victim(config, cache_dir, monkeypatch)),
                         daemon=True)
    t.start()
    t.join(30)
    assert not t.is_alive(), "reading the key hangs"
    (c, v), msgs = done["r"]
    assert v == {"v": 1.0} and c.rejected == 1  # mallory's entry recomputed, not reused
    assert not c.persistent_key and c.secret == cache._PROCESS_KEY
    (msg,) = msgs
    assert fragment in msg and str(config / "cache-key") in msg and "nothing in OUT/.cache is " \
        "reused" in msg
    if kind not in ("folder", "fifo", "dangling", "link"):
        assert (config / "cache-key").exists()  # never overwritten or removed


def test_a_trusted_key_is_used_and_made_0600(tmp_path, monkeypatch):
    from torlab.protocols.cache import ResultCache

    cache_dir = tmp_path / "out" / ".cache"
    _store_with(tmp_path / "me", cache_dir, KEY, monkeypatch)
    (c, v), msgs = _victim(tmp_path / "me", cache_dir, monkeypatch)
    assert v == {"v": 666.0} and c.persistent_key and not msgs  # my own entry: reused
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(tmp_path / "new" / "torlab"))
    n = ResultCache(tmp_path / "c2")
    assert n.secret and n.persistent_key
    key = tmp_path / "new" / "torlab" / "cache-key"
    assert key.stat().st_mode & 0o777 == 0o600 and key.parent.stat().st_mode & 0o777 == 0o700
    assert len(bytes.fromhex(key.read_text().strip())) == 32


@pytest.mark.parametrize("env", ["XDG_CONFIG_HOME", "TORLAB_CONFIG_DIR"])
def test_a_relative_configuration_folder_is_ignored(tmp_path, monkeypatch, env):
    from torlab.protocols.cache import cache_key_file

    monkeypatch.delenv("TORLAB_CONFIG_DIR", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(env, "relative/config")
    assert cache_key_file() == tmp_path / "home" / ".config" / "torlab" / "cache-key"
    from torlab.protocols.cache import ResultCache

    with pytest.warns(TorlabWarning, match=f"{env}='relative/config' is a relative path"):
        c = ResultCache(tmp_path / "c")
        assert c.secret and c.persistent_key
    assert not (tmp_path / "relative").exists()

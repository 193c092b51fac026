"""The private, authenticated folder behind the compiled-kernel cache (dampfit.files.private).

In-process checks of every rule: the folders on the way down, the folder itself, each entry
(owner, mode, type, size, tag) and the key. Loading executables from such a folder is tested
end to end in tests/invariants/test_executables.py.
"""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import pytest

from dampfit.files.private import KEY_NAME, UnsafeFolder, open_store

ROOT = os.geteuid() == 0


def _store(tmp_path: Path, name: str = "cache"):
    return open_store(tmp_path / name)


def test_created_private_under_any_umask_and_entries_round_trip(tmp_path):
    old = os.umask(0)
    try:
        store = open_store(tmp_path / "a" / "b" / "cache")
        store.write("k-1.exe", b"payload")
    finally:
        os.umask(old)
    assert store.created == [tmp_path / "a", tmp_path / "a" / "b", tmp_path / "a" / "b" / "cache"]
    for p in store.created:
        assert stat.S_IMODE(p.stat().st_mode) == 0o700
    for name in (KEY_NAME, "k-1.exe"):
        assert stat.S_IMODE((store.path / name).stat().st_mode) == 0o600
    assert store.read("k-1.exe") == b"payload"
    assert open_store(store.path).read("k-1.exe") == b"payload"  # another opening, same key
    assert store.read("missing.exe") is None and store.discarded == 0
    assert not [p for p in store.path.iterdir() if p.name.startswith(".tmp")]


@pytest.mark.parametrize("mode, reason", [
    (0o770, "writable by its group"), (0o707, "writable by everyone"), (0o1777, None),
    (0o755, None)])
def test_folders_on_the_way_down(tmp_path, mode, reason):
    above = tmp_path / "above"
    above.mkdir()
    above.chmod(mode)
    if reason is None:
        assert open_store(above / "x" / "cache").path == above / "x" / "cache"
        return
    with pytest.raises(UnsafeFolder, match=f"its parent {above} is {reason}"):
        open_store(above / "x" / "cache")
    assert not (above / "x").exists()  # nothing created below it


def test_a_folder_that_is_not_private_itself(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    for mode in (0o1777, 0o770, 0o702):  # sticky does not help the folder itself
        cache.chmod(mode)
        with pytest.raises(UnsafeFolder, match=r"writable by group or others \(mode"):
            open_store(cache)
    (tmp_path / "file").write_text("")
    with pytest.raises(UnsafeFolder, match="not a directory"):
        open_store(tmp_path / "file" / "cache")


@pytest.mark.skipif(not ROOT, reason="only root can give a folder to another user")
def test_folders_of_another_user(tmp_path):
    theirs = tmp_path / "theirs"
    theirs.mkdir(mode=0o755)
    os.chown(theirs, 4321, -1)
    with pytest.raises(UnsafeFolder, match=f"its parent {theirs} belongs to another user"):
        open_store(theirs / "cache")
    with pytest.raises(UnsafeFolder, match=f"{theirs} belongs to another user"):
        open_store(theirs)


def test_a_symlinked_path_is_resolved_and_the_real_folders_checked(tmp_path):
    real = tmp_path / "real"
    real.mkdir(mode=0o700)
    (tmp_path / "link").symlink_to(real)
    store = open_store(tmp_path / "link" / "cache")
    assert store.path == real / "cache"
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    (shared / "cache").mkdir(mode=0o700)
    (tmp_path / "innocent").symlink_to(shared / "cache")
    with pytest.raises(UnsafeFolder, match=f"its parent {shared} is writable by everyone"):
        open_store(tmp_path / "innocent")


def test_a_folder_opened_then_opened_up_is_no_longer_used(tmp_path):
    store = _store(tmp_path)
    store.write("e.exe", b"x")
    store.path.chmod(0o777)
    with pytest.raises(UnsafeFolder, match="writable by group or others"):
        store.read("e.exe")
    with pytest.raises(UnsafeFolder, match="writable by group or others"):
        store.write("e.exe", b"y")


def test_every_flipped_bit_is_refused_and_the_entry_deleted(tmp_path):
    store = _store(tmp_path)
    body = bytes(range(40))
    store.write("e.exe", body)
    path = store.path / "e.exe"
    good = path.read_bytes()
    for at in range(len(good)):
        for bit in (0, 3, 7):
            data = bytearray(good)
            data[at] ^= 1 << bit
            path.write_bytes(bytes(data))
            assert store.read("e.exe") is None, (at, bit)
            assert not path.exists()
    assert store.discarded == 3 * len(good)
    for bad in (good[:-1], good + b"\0", b"", good[:31]):  # truncated, extended, short
        path.write_bytes(bad)
        assert store.read("e.exe") is None
    store.write("e.exe", body)
    assert store.read("e.exe") == body


def test_an_entry_under_another_name_is_refused(tmp_path):
    store = _store(tmp_path)
    store.write("a.exe", b"code")
    os.rename(store.path / "a.exe", store.path / "b.exe")
    assert store.read("b.exe") is None


@pytest.mark.parametrize("make", ["fifo", "symlink", "mode", "dir", "big"])
def test_entries_that_are_not_private_regular_files(tmp_path, make):
    store = _store(tmp_path)
    store.write("e.exe", b"code")
    path = store.path / "e.exe"
    if make == "fifo":  # must neither hang nor be read
        path.unlink()
        os.mkfifo(path, 0o600)
    elif make == "symlink":
        target = tmp_path / "target"
        target.write_bytes(path.read_bytes())
        target.chmod(0o600)
        path.unlink()
        path.symlink_to(target)
    elif make == "mode":
        path.chmod(0o640)
    elif make == "dir":
        path.unlink()
        path.mkdir()
    result = []
    if make == "big":
        thread = threading.Thread(target=lambda: result.append(store.read("e.exe", limit=2)))
    else:
        thread = threading.Thread(target=lambda: result.append(store.read("e.exe")))
    thread.start()
    thread.join(30)
    assert not thread.is_alive() and result == [None]
    if make in ("fifo", "symlink", "mode", "big"):
        assert not os.path.lexists(path)  # deleted from the private folder
    if make == "symlink":
        assert (tmp_path / "target").exists()


@pytest.mark.skipif(not ROOT, reason="only root can give a file to another user")
def test_an_entry_of_another_user_is_refused(tmp_path):
    store = _store(tmp_path)
    store.write("e.exe", b"code")
    os.chown(store.path / "e.exe", 4321, -1)
    assert store.read("e.exe") is None


def test_a_lost_or_replaced_key_untrusts_every_entry(tmp_path):
    store = _store(tmp_path)
    store.write("e.exe", b"code")
    key = store.path / KEY_NAME
    key.unlink()
    assert open_store(store.path).read("e.exe") is None  # a new key was made
    store = _store(tmp_path)
    store.write("e.exe", b"code")
    key.write_bytes(os.urandom(32))
    assert open_store(store.path).read("e.exe") is None
    for bad in ("symlink", "short", "mode"):
        store = _store(tmp_path)
        store.write("e.exe", b"code")
        key.unlink()
        if bad == "symlink":
            (tmp_path / "their.key").write_bytes(b"k" * 32)
            key.symlink_to(tmp_path / "their.key")
        elif bad == "short":
            key.write_bytes(b"k" * 16)
        else:
            key.write_bytes(b"k" * 32)
            key.chmod(0o644)
        again = open_store(store.path)
        assert again.read("e.exe") is None, bad
        st = key.lstat()
        assert stat.S_ISREG(st.st_mode) and stat.S_IMODE(st.st_mode) == 0o600
        assert st.st_size == 32 and key.read_bytes() != b"k" * 32
    assert (tmp_path / "their.key").read_bytes() == b"k" * 32


def test_names_cannot_leave_the_folder(tmp_path):
    store = _store(tmp_path)
    for name in ("../x", "/etc/passwd", ".hidden", KEY_NAME, "a/b", ""):
        with pytest.raises(ValueError, match="not an entry name"):
            store.write(name, b"x")
        with pytest.raises(ValueError, match="not an entry name"):
            store.read(name)

"""A folder only this user can change, holding files this user's dampfit signed.

The store behind the compiled-kernel cache (:mod:`dampfit.inference.executables`), whose
entries are loaded as code: an entry someone else could write or swap would run as the user.
:func:`open_store` trusts a folder only when

* every folder from ``/`` down to it — of its real path, symbolic links resolved first — is
  owned by this user or by root, and none is writable by its group or by others unless it has
  the sticky bit (``/tmp``): nobody else can rename, replace or swap anything on the way
  (:func:`_walk` opens each component with ``O_NOFOLLOW`` relative to the one above and checks
  it with ``fstat``, so a component swapped while it is checked is noticed, not followed);
* the folder itself is owned by this user and writable by nobody else. It is then used only
  through the file descriptor the walk opened (``openat`` and friends), and re-checked with
  ``fstat`` before every read and write.

Every file in it is authenticated: HMAC-SHA256 (:mod:`hmac`) over its name and content, with a
random 256-bit key kept in the folder (:data:`KEY_NAME`, mode 0600, created with
``O_EXCL | O_NOFOLLOW`` and published with ``link``, so a second process never reads half a
key; checked like an entry, and replaced by a new key — which untrusts every entry — if it
fails). :meth:`PrivateStore.read` opens an entry with ``O_NOFOLLOW | O_NONBLOCK`` and accepts it
only if ``fstat`` says: a regular file, owned by this user, mode 0600, at most
:data:`MAX_ENTRY` bytes — and its tag verifies. Anything else (a symbolic link, a FIFO, a
file of another owner or mode, a flipped bit, a key that was replaced or lost) is deleted from
the folder and reported as missing; its content is never handed on. A failed check of the
folder raises :class:`UnsafeFolder` with the one-line reason.

The key in the folder guards against what the permission checks cannot see: a damaged entry
(a flipped bit must never reach a deserialiser), an entry copied in from another machine or
account (a backup, a synchronised home folder), and a file a confused program wrote there.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import re
import secrets
import stat
from pathlib import Path

#: Name of the HMAC key file inside the folder.
KEY_NAME = "hmac.key"
#: Size of the key [bytes] (and of a tag, HMAC-SHA256).
KEY_SIZE = TAG_SIZE = 32
#: Largest entry read [bytes]; a larger file is not trusted (a compiled kernel is ≈ 1 MB).
MAX_ENTRY = 256 * 2**20
#: Names an entry may have (no path separators, no leading dot: temporary files have one).
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]{0,199}")
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
#: Opening a folder on the walk: search permission suffices with O_PATH (Linux).
_DIR = os.O_DIRECTORY | os.O_NOFOLLOW | _CLOEXEC | getattr(os, "O_PATH", os.O_RDONLY)
_FILE = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | _CLOEXEC  # a FIFO must not block


class UnsafeFolder(Exception):
    """The folder must not be used; the message says why (one line)."""


class _Untrusted(Exception):
    """A file in the folder that fails its checks."""


def _supported() -> bool:
    return all(f in os.supports_dir_fd for f in (os.open, os.mkdir, os.unlink, os.rename,
                                                 os.link))


def _check_parent(st: os.stat_result, path: Path, uid: int) -> None:
    if not stat.S_ISDIR(st.st_mode):
        raise UnsafeFolder(f"its parent {path} is not a directory")
    if st.st_uid not in (uid, 0):
        raise UnsafeFolder(f"its parent {path} belongs to another user (uid {st.st_uid})")
    if st.st_mode & 0o022 and not st.st_mode & stat.S_ISVTX:
        who = "everyone" if st.st_mode & 0o002 else "its group"
        raise UnsafeFolder(f"its parent {path} is writable by {who} "
                           f"(mode {stat.S_IMODE(st.st_mode):o}, no sticky bit)")


def _check_own(st: os.stat_result, path: Path, uid: int) -> None:
    if not stat.S_ISDIR(st.st_mode):
        raise UnsafeFolder(f"{path} is not a directory")
    if st.st_uid != uid:
        raise UnsafeFolder(f"{path} belongs to another user (uid {st.st_uid})")
    if st.st_mode & 0o022:
        raise UnsafeFolder(f"{path} is writable by group or others "
                           f"(mode {stat.S_IMODE(st.st_mode):o})")


def _walk(path: Path, create: bool, uid: int) -> tuple[int, Path, list[Path]]:
    """Open the real path of ``path`` component by component from ``/`` (module docstring);
    create missing folders 0700 if ``create``. Returns (descriptor, real path, created)."""
    real = Path(os.path.realpath(path))
    fd = os.open("/", _DIR)
    cur, created = Path("/"), []
    try:
        parts = real.parts[1:]
        if parts:
            _check_parent(os.fstat(fd), cur, uid)
        for i, name in enumerate(parts):
            cur = cur / name
            try:
                nfd = os.open(name, _DIR, dir_fd=fd)
            except FileNotFoundError:
                if not create:
                    raise UnsafeFolder(f"{cur} does not exist") from None
                try:
                    os.mkdir(name, 0o700, dir_fd=fd)
                    created.append(cur)
                except FileExistsError:
                    pass
                nfd = os.open(name, _DIR, dir_fd=fd)
            except (NotADirectoryError, OSError) as exc:
                if isinstance(exc, PermissionError):
                    raise
                raise UnsafeFolder(f"{cur} is not a directory, or became a symbolic link while "
                                   "it was checked") from None
            os.close(fd)
            fd = nfd
            (_check_own if i == len(parts) - 1 else _check_parent)(os.fstat(fd), cur, uid)
        if not parts:
            _check_own(os.fstat(fd), cur, uid)
        return fd, real, created
    except BaseException:
        os.close(fd)
        raise


def open_store(path: str | os.PathLike, *, create: bool = True) -> "PrivateStore":
    """The store in folder ``path`` (created 0700, with its missing parents, if ``create``).

    Raises :class:`UnsafeFolder` if it must not be used (module docstring) and
    :class:`OSError` if it cannot be created or read (a read-only home folder)."""
    if not _supported():
        raise UnsafeFolder("this platform cannot open folders relative to a checked one")
    uid = os.geteuid()
    fd, real, created = _walk(Path(os.path.abspath(path)), create, uid)
    try:
        return PrivateStore(fd, real, created, uid)
    except BaseException:
        os.close(fd)
        raise


class PrivateStore:
    """An open, checked folder of authenticated files (module docstring); from
    :func:`open_store`."""

    def __init__(self, fd: int, path: Path, created: list[Path], uid: int):
        self._fd = fd
        self._uid = uid
        #: The folder's real path, and the folders :func:`open_store` created for it.
        self.path, self.created = path, created
        #: Files found untrusted and deleted (a count, for tests and diagnostics).
        self.discarded = 0
        self._key = self._load_key()

    def close(self) -> None:
        """Release the folder's descriptor (the store can no longer be used)."""
        fd, self._fd = self._fd, -1
        if fd >= 0:
            os.close(fd)

    def __del__(self):  # pragma: no cover - best effort at interpreter exit
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass

    # ------------------------------------------------------------------ files
    def _check_folder(self) -> None:
        """The folder is still this user's and writable by nobody else (it may have been
        changed since it was opened); else :class:`UnsafeFolder`."""
        if self._fd < 0:
            raise UnsafeFolder(f"{self.path} was closed")
        _check_own(os.fstat(self._fd), self.path, self._uid)

    def _read_file(self, name: str, limit: int) -> bytes | None:
        """Content of the file ``name`` after the checks of the module docstring; None if
        it does not exist; :class:`_Untrusted` if it fails them."""
        try:
            fd = os.open(name, _FILE, dir_fd=self._fd)
        except FileNotFoundError:
            return None
        except OSError as exc:  # ELOOP: a symbolic link; EACCES, ENXIO: not ours to read
            raise _Untrusted(f"cannot be opened safely ({exc.strerror or exc})") from None
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise _Untrusted("is not a regular file")
            if st.st_uid != self._uid:
                raise _Untrusted(f"belongs to another user (uid {st.st_uid})")
            if stat.S_IMODE(st.st_mode) != 0o600:
                raise _Untrusted(f"has mode {stat.S_IMODE(st.st_mode):o}, not 600")
            if st.st_size > limit:
                raise _Untrusted(f"is larger than {limit} bytes")
            chunks, left = [], st.st_size + 1  # one byte more: a file that grew is seen
            while left > 0:
                chunk = os.read(fd, min(left, 1 << 20))
                if not chunk:
                    break
                chunks.append(chunk)
                left -= len(chunk)
            data = b"".join(chunks)
            if len(data) != st.st_size:
                raise _Untrusted("changed while it was read")
            return data
        finally:
            os.close(fd)

    def _write_file(self, name: str, data: bytes) -> None:
        """Write ``name`` atomically (a private temporary file renamed into place)."""
        tmp = f".tmp-{secrets.token_hex(8)}"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | _CLOEXEC,
                     0o600, dir_fd=self._fd)
        try:
            os.fchmod(fd, 0o600)  # whatever the umask
            with os.fdopen(fd, "wb", closefd=False) as fh:
                fh.write(data)
            os.close(fd)
            fd = -1
            os.replace(tmp, name, src_dir_fd=self._fd, dst_dir_fd=self._fd)
        except BaseException:
            if fd >= 0:
                os.close(fd)
            self._unlink(tmp)
            raise

    def _unlink(self, name: str) -> None:
        try:
            os.unlink(name, dir_fd=self._fd)
        except OSError:
            pass

    # ------------------------------------------------------------------ the key
    def _load_key(self) -> bytes:
        """The folder's HMAC key. A missing key, or a key file that is not a private
        32-byte file of this user, is replaced by a new random key: every entry signed with
        the old one is then untrusted (deleted when it is next read)."""
        self._check_folder()
        for _ in range(3):
            try:
                key = self._read_file(KEY_NAME, KEY_SIZE)
            except _Untrusted:
                key = b""
            if key is not None and len(key) == KEY_SIZE:
                return key
            if key is not None:
                self.discarded += 1
                self._unlink(KEY_NAME)
            tmp = f".tmp-key-{secrets.token_hex(8)}"
            self._write_file(tmp, secrets.token_bytes(KEY_SIZE))
            try:  # link: the key appears complete or not at all; a concurrent creator wins
                os.link(tmp, KEY_NAME, src_dir_fd=self._fd, dst_dir_fd=self._fd)
            except FileExistsError:
                pass
            finally:
                self._unlink(tmp)
        raise UnsafeFolder(f"its key file {self.path / KEY_NAME} cannot be created")

    def _tag(self, name: str, body: bytes) -> bytes:
        return hmac.new(self._key, name.encode() + b"\0" + body, hashlib.sha256).digest()

    # ------------------------------------------------------------------ entries
    def read(self, name: str, limit: int = MAX_ENTRY) -> bytes | None:
        """The content stored as ``name``, or None if there is none that this user's dampfit
        wrote and that is intact (an untrusted file is deleted: module docstring).
        :class:`UnsafeFolder` if the folder itself is no longer private."""
        _valid(name)
        self._check_folder()
        try:
            data = self._read_file(name, limit + TAG_SIZE)
        except _Untrusted:
            data = b""
        if data is None:
            return None
        body, tag = data[:-TAG_SIZE], data[-TAG_SIZE:]
        if len(data) < TAG_SIZE or not hmac.compare_digest(tag, self._tag(name, body)):
            self.discard(name)
            return None
        return body

    def write(self, name: str, body: bytes) -> None:
        """Store ``body`` as ``name`` with its tag (atomically; mode 0600)."""
        _valid(name)
        self._check_folder()
        self._write_file(name, body + self._tag(name, body))

    def discard(self, name: str) -> None:
        """Delete ``name`` from the folder (whatever it is: the folder is private)."""
        _valid(name)
        self.discarded += 1
        self._unlink(name)


def _valid(name: str) -> None:
    if not _NAME.fullmatch(name) or name == KEY_NAME:
        raise ValueError(f"not an entry name: {name!r}")

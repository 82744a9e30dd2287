"""ASCII paths for pybullet's ``createCollisionShapeArray``, which crashes on any other file name.

pybullet 3.2.7 reads the ``fileNames`` list of ``createCollisionShapeArray`` with a conversion that fails
for a path holding non-ASCII characters, and then dereferences the failure: the physics process dies of a
segmentation fault (measured on a build in ``/tmp/Bâtiment 3/建物``; ``bytes`` crash the same way). Its
single-file calls (``createCollisionShape``, ``createVisualShape``, ``loadURDF``) take such paths.

So a mesh whose path is not ASCII is given to pybullet through a symbolic link to its folder, made in a
temporary folder of this process (``bimbot-physics-*`` in the system's temporary folder, removed at exit,
symbolic links only: the build is never touched). pybullet reads the very same file, so the collision
shapes are exactly those of an ASCII path. Paths that are ASCII already are passed through unchanged.
Where no symbolic link can be made, the file itself is copied there.
"""

from __future__ import annotations

import atexit
import logging
import os
import shutil
import tempfile
import threading
from pathlib import Path

from bimbot.shared.errors import InputError

_log = logging.getLogger(__name__)

FALLBACK_TEMP_DIRS = ("/tmp", "/var/tmp")  # when the system's temporary folder is not ASCII itself


class AsciiLinks:
    """ASCII stand-ins for file paths, made in one temporary folder that :meth:`close` removes."""

    def __init__(self, temp_parent: Path | None = None) -> None:
        self._temp_parent = temp_parent
        self._root: Path | None = None
        self._folders: dict[Path, Path] = {}  # real folder → its link in the root
        self._files: dict[Path, Path] = {}  # real file → its link or copy (a non-ASCII file name)
        self._lock = threading.Lock()

    @property
    def root(self) -> Path | None:
        """The temporary folder, once a link was needed."""
        return self._root

    def path(self, file: Path) -> str:
        """``file`` as a path pybullet's array calls can take: itself when ASCII, else an ASCII link."""
        text = os.fsdecode(file)
        if text.isascii():
            return text
        with self._lock:
            return str(self._stand_in(Path(text).absolute()))

    def _stand_in(self, file: Path) -> Path:
        root = self._make_root()
        if file.name.isascii():
            folder = self._folders.get(file.parent)
            if folder is None:
                folder = root / f"d{len(self._folders)}"
                try:
                    folder.symlink_to(file.parent, target_is_directory=True)
                except OSError:
                    return self._file_stand_in(root, file)
                self._folders[file.parent] = folder
            return folder / file.name
        return self._file_stand_in(root, file)

    def _file_stand_in(self, root: Path, file: Path) -> Path:
        known = self._files.get(file)
        if known is not None:
            return known
        suffix = file.suffix if file.suffix.isascii() else ""
        stand_in = root / f"f{len(self._files)}{suffix}"
        try:
            stand_in.symlink_to(file)
        except OSError:
            shutil.copyfile(file, stand_in)
        self._files[file] = stand_in
        return stand_in

    def _make_root(self) -> Path:
        if self._root is None:
            parent = self._temp_parent or _ascii_temp_dir()
            self._root = Path(tempfile.mkdtemp(prefix="bimbot-physics-", dir=parent))
            _log.info("mesh paths that are not ASCII are read through links in %s", self._root)
        return self._root

    def close(self) -> None:
        """Remove the temporary folder (links and copies only: what they point to stays)."""
        with self._lock:
            if self._root is not None:
                shutil.rmtree(self._root, ignore_errors=True)  # does not follow the links
                self._root = None
            self._folders.clear()
            self._files.clear()


def _ascii_temp_dir() -> Path:
    for candidate in (tempfile.gettempdir(), *FALLBACK_TEMP_DIRS):
        if candidate.isascii() and os.path.isdir(candidate) and os.access(candidate, os.W_OK | os.X_OK):
            return Path(candidate)
    raise InputError(
        "the build's path holds non-ASCII characters, which pybullet cannot open, and no ASCII temporary "
        "folder is writable to link it from (set TMPDIR to one)"
    )


_LINKS = AsciiLinks()
atexit.register(_LINKS.close)


def pybullet_path(file: Path) -> str:
    """``file`` for pybullet's ``createCollisionShapeArray`` (see the module docstring)."""
    return _LINKS.path(file)

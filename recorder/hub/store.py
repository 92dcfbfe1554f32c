"""The hub folder: push (stage, copy and hash, check, rename), versions, verify, pull and the latest-version links.

Layout (docs/hub.md): ``<hub>/USER/NAME@vN/`` is version N, a complete LeRobot dataset plus its manifest;
``<hub>/USER/NAME`` is a symlink to the newest ``NAME@vN``. Versions never change once published.
"""

from __future__ import annotations

import datetime
import errno
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from recorder import GloverecError, __version__, dataset_check as dataset
from recorder.hub import atomic, manifest, names
from recorder.paths import HUB_ENV, hub_dir

_VERSION_DIR = re.compile(r"(?P<name>[A-Za-z0-9][A-Za-z0-9._-]*)@v(?P<number>[1-9][0-9]*)")


@dataclass(frozen=True)
class Version:
    """One published version of a dataset: ``<hub>/USER/NAME@vN``."""

    repo_id: str
    number: int
    path: Path

    @property
    def tag(self) -> str:
        return names.tag(self.number)

    def manifest(self) -> dict:
        return manifest.read(self.path)


@dataclass
class Check:
    """The verdict on one version: what differs from its manifest, or why the manifest itself is unusable."""

    version: Version
    damage: manifest.Damage = field(default_factory=manifest.Damage)
    problem: str = ""
    files: int = 0

    @property
    def ok(self) -> bool:
        return not (self.problem or self.damage)

    def describe(self) -> str:
        return self.problem or self.damage.summary() or f"{self.files} files ok"


@dataclass
class Report:
    """What `verify` found and did: per-version checks, stale temporaries removed, latest links repaired."""

    checks: list[Check]
    cleaned: list[str] = field(default_factory=list)
    relinked: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.errors and all(c.ok for c in self.checks)


class Hub:
    """A local hub folder (``paths.hub_dir`` picks it: --hub, $GLOVEREC_HUB or datasets/hub)."""

    def __init__(self, root: str | os.PathLike | None = None):
        self.root = hub_dir(root)

    # ------------------------------------------------------------ reading

    def repo_ids(self) -> list[str]:
        """Every USER/NAME with at least one version folder."""
        self._require()
        found = set()
        for user in self._users():
            for entry in user.iterdir():
                m = _VERSION_DIR.fullmatch(entry.name)
                if m and entry.is_dir() and not entry.is_symlink():
                    found.add(f"{user.name}/{m.group('name')}")
        return sorted(found)

    def versions(self, repo_id: str) -> list[Version]:
        """The versions of ``repo_id``, oldest first (empty if it has none)."""
        user, name = names.parse_repo_id(repo_id)
        folder = self.root / user
        out = []
        for entry in folder.iterdir() if folder.is_dir() else ():
            m = _VERSION_DIR.fullmatch(entry.name)
            if m and m.group("name") == name and entry.is_dir() and not entry.is_symlink():
                out.append(Version(repo_id, int(m.group("number")), entry))
        return sorted(out, key=lambda v: v.number)

    def version(self, repo_id: str, version: str | None = None) -> Version:
        """Version ``vN`` of ``repo_id``, or its newest when ``version`` is None."""
        names.parse_repo_id(repo_id)
        self._require()
        have = self.versions(repo_id)
        if not have:
            raise GloverecError(
                f"no dataset {repo_id} in the hub {self.root} (`gloverec hub list` shows what is there)"
            )
        if version is None:
            return have[-1]
        number = names.parse_version(version)
        for v in have:
            if v.number == number:
                return v
        raise GloverecError(
            f"{repo_id} has no version {names.tag(number)} in {self.root} (it has {', '.join(v.tag for v in have)})"
        )

    def checked(self, repo_id: str, version: str | None = None) -> Version:
        """Version ``vN`` (the newest by default), every file checked against its manifest first: a damaged
        version is a one-line GloverecError, never a dataset that fails to load halfway through a command."""
        v = self.version(repo_id, version)
        check = self.check(v)
        if not check.ok:
            raise GloverecError(
                f"{repo_id} {v.tag} in {self.root} is damaged ({check.describe()}): `gloverec hub verify` checks "
                "every version; push the recording again to publish a sound one, or publish its intact episodes "
                "with `gloverec repair --hub`"
            )
        return v

    def link(self, repo_id: str) -> Path:
        """``<hub>/USER/NAME``: the symlink to the newest version, what `LeRobotDataset(root=...)` is given."""
        user, name = names.parse_repo_id(repo_id)
        return self.root / user / name

    def latest(self, repo_id: str) -> str | None:
        """The version tag the link points to (None if there is no link yet)."""
        target = atomic.read_link(self.link(repo_id))
        m = _VERSION_DIR.fullmatch(target or "")
        return names.tag(int(m.group("number"))) if m else None

    def twin(self, version: Version) -> Version | None:
        """An older version with exactly the same files and contents, if any (the newest such)."""
        files = version.manifest()["files"]
        for older in reversed(self.versions(version.repo_id)):
            if older.number < version.number:
                try:
                    if older.manifest()["files"] == files:
                        return older
                except GloverecError:
                    continue
        return None

    # ------------------------------------------------------------ writing

    def push(self, src: str | os.PathLike, repo_id: str) -> Version:
        """Publish the dataset at ``src`` as the next version of ``repo_id`` and point the link at the newest.

        The files are copied and hashed into a staging folder in ``<hub>/USER``, checked there (so the checks
        see exactly what gets published), sealed, then renamed to ``NAME@vN`` in one step. A crash at any moment
        leaves either no new version or a complete one, plus at most a stale staging folder.
        """
        user, name = names.parse_repo_id(repo_id)
        src = Path(src)
        dataset.looks_like_dataset(src)
        if _inside(self.root, src):
            raise GloverecError(f"the hub {self.root} is inside the dataset {src}: use another --hub")
        taken = manifest.dataset_files(src)
        nested = sorted(rel.removesuffix("/meta/info.json") for rel in taken if rel.endswith("/meta/info.json"))
        if nested:  # e.g. lerobot-edit-dataset 0.4.4 --new_repo_id wrote its result inside the --root dataset
            raise GloverecError(f"{src} holds another dataset inside it ({nested[0]}/): move it out and push each "
                                "on its own (docs/lerobot.md)")  # fmt: skip
        folder, staging = self.root / user, None
        try:
            folder.mkdir(parents=True, exist_ok=True)
            atomic.clean_stale(folder)
            _clear_link_slot(self.link(repo_id))
            staging = atomic.temp_dir(folder, name)
            files = manifest.hash_files(src, taken, staging, f"copying {repo_id}")
            info = dataset.check_dataset(staging, shown_as=src)
            version = self._publish(
                staging,
                repo_id,
                {
                    "format": manifest.FORMAT,
                    "repo_id": repo_id,
                    "gloverec": __version__,
                    "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                    "source": str(src.resolve()),
                    "dataset": {
                        k: info.get(k)
                        for k in (
                            "codebase_version",
                            "fps",
                            "robot_type",
                            "total_episodes",
                            "total_frames",
                            "total_tasks",
                        )
                    },
                    "files": files,
                },
            )
            self.relink(repo_id)
        except BaseException as exc:
            if staging is not None and staging.exists():
                atomic.remove(staging)
            if isinstance(exc, OSError):
                raise GloverecError(f"cannot push to {folder}: {exc.strerror or exc}") from None
            raise
        return version

    def _next_number(self, repo_id: str) -> int:
        have = self.versions(repo_id)
        return have[-1].number + 1 if have else 1

    def _publish(self, staging: Path, repo_id: str, meta: dict) -> Version:
        """Seal ``staging`` and rename it to the first free ``NAME@vN``. rename(2) refuses a non-empty target and
        every version folder holds a manifest, so two pushes racing for one number cannot both get it: the loser
        rewrites its manifest and takes N+1."""
        user, name = names.parse_repo_id(repo_id)
        number = self._next_number(repo_id)
        while True:
            (staging / manifest.NAME).unlink(missing_ok=True)
            manifest.write(staging, {**meta, "version": names.tag(number)})
            atomic.seal(staging)
            target = self.root / user / f"{name}@{names.tag(number)}"
            try:
                os.rename(staging, target)
            except OSError as exc:
                if exc.errno in (errno.EEXIST, errno.ENOTEMPTY, errno.EISDIR, errno.ENOTDIR):
                    number += 1
                    continue
                raise GloverecError(f"cannot publish {target}: {exc.strerror or exc}") from None
            atomic.fsync_dir(target.parent)
            return Version(repo_id, number, target)

    def relink(self, repo_id: str) -> str | None:
        """Point ``<hub>/USER/NAME`` at the newest version; return its tag (None if there is no version).

        Lock-free with concurrent pushes: each re-reads the versions after switching and switches again until the
        link and the newest version agree, so the last switch always names the newest version.
        """
        link = self.link(repo_id)
        while True:
            have = self.versions(repo_id)
            if not have:
                return None
            target = have[-1].path.name
            if atomic.read_link(link) != target:
                self._point(link, target)
            if self.versions(repo_id)[-1].path.name == target and atomic.read_link(link) == target:
                return have[-1].tag

    def _point(self, link: Path, target: str) -> None:
        _clear_link_slot(link)
        atomic.point_link(link, target)

    def pull(self, repo_id: str, version: str | None, dest: str | os.PathLike) -> Version:
        """Copy a version out to ``dest`` (new or empty), checking every byte against the manifest on the way."""
        v = self.version(repo_id, version)
        dest = Path(dest)
        if _inside(self.root, dest) or _inside(dest, self.root):
            raise GloverecError(f"cannot pull into {dest}: it overlaps the hub {self.root}")
        if dest.exists() and not (dest.is_dir() and not any(dest.iterdir())):
            raise GloverecError(f"{dest} already exists: pull into a new or empty folder")
        expected = v.manifest()
        staging = None
        try:
            dest.parent.mkdir(parents=True, exist_ok=True)
            staging = atomic.temp_dir(dest.parent, dest.name)
            damage = manifest.compare(v.path, expected, staging, f"pulling {repo_id} {v.tag}")
            if damage:
                raise GloverecError(f"{repo_id} {v.tag} in {self.root} is damaged ({damage.summary()}): not pulled")
            atomic.seal(staging, read_only=False)
            os.rename(staging, dest)
        except BaseException as exc:
            if staging is not None:
                atomic.remove(staging)
            if isinstance(exc, OSError):
                raise GloverecError(f"cannot pull into {dest}: {exc.strerror or exc}") from None
            raise
        return v

    def verify(self, repo_id: str | None = None, version: str | None = None) -> Report:
        """Check every file of the chosen versions (all by default) against its manifest; on the way remove stale
        temporaries and repair latest-version links that an interrupted push left behind."""
        self._require()
        if version is not None and repo_id is None:
            raise GloverecError("--version needs --repo-id")
        if repo_id is not None:
            targets = [self.version(repo_id, version)] if version else self.versions(repo_id)
            if not targets:
                self.version(repo_id)  # raises: no such dataset
        else:
            targets = [v for r in self.repo_ids() for v in self.versions(r)]
        report = Report([self.check(v) for v in targets])
        for user in self._users():
            report.cleaned += [f"{user.name}/{n}" for n in atomic.clean_stale(user)]
        for rid in sorted({v.repo_id for v in targets}):
            before = atomic.read_link(self.link(rid))
            try:
                tag = self.relink(rid)
            except (GloverecError, OSError) as exc:
                report.errors.append(f"{rid}: {exc}")
                continue
            if atomic.read_link(self.link(rid)) != before:
                report.relinked.append(f"{rid} -> {tag}")
        return report

    def check(self, v: Version) -> Check:
        """Version ``v``'s files against its manifest."""
        try:
            m = v.manifest()
        except GloverecError as exc:
            return Check(v, problem=str(exc))
        if m.get("repo_id") != v.repo_id or m.get("version") != v.tag:
            return Check(v, problem=f"its manifest belongs to {m.get('repo_id')} {m.get('version')}")
        return Check(v, manifest.compare(v.path, m, label=f"verifying {v.repo_id} {v.tag}"), files=len(m["files"]))

    def _users(self) -> list[Path]:
        return (
            sorted(p for p in self.root.iterdir() if p.is_dir() and not p.name.startswith("."))
            if self.root.is_dir()
            else []
        )

    def _require(self) -> None:
        if not self.root.is_dir():
            raise GloverecError(f"no hub at {self.root} (push a dataset first, or pass --hub or set {HUB_ENV})")


def _clear_link_slot(link: Path) -> None:
    """Make room for the latest-version link: a real folder there is removed if it holds no file (what a
    `LeRobotDataset(root=<hub>/USER/NAME)` tried before the first push leaves), else it is an error."""
    if link.is_dir() and not link.is_symlink():
        if manifest.all_files(link):
            raise GloverecError(f"{link} is a folder, not the hub's link to the newest version: move it away")
        atomic.remove(link)


def _inside(inner: Path, outer: Path) -> bool:
    """Whether ``inner`` is ``outer`` or lies under it (paths resolved; they need not exist)."""
    return inner.resolve().is_relative_to(outer.resolve())

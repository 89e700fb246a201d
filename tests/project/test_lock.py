"""The environment the tests run in is the lock: every distribution installed is the version
requirements/test.txt pins for this interpreter, and nothing else is installed but viewslam
itself. A drifted venv (an upgrade by hand, a package left from an earlier lock) fails here
rather than moving the figures silently."""

import re
from importlib.metadata import distributions
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

LOCK = Path(__file__).resolve().parents[2] / "requirements" / "test.txt"


def locked() -> dict[str, str]:
    """Name to version of every requirement of the lock whose marker holds here."""
    pins = {}
    for line in LOCK.read_text().splitlines():
        if not line or line[0] in " #":
            continue
        requirement = Requirement(line.rstrip(" \\"))
        if requirement.marker is None or requirement.marker.evaluate():
            (specifier,) = requirement.specifier
            pins[canonicalize_name(requirement.name)] = specifier.version
    return pins


def installed() -> dict[str, str]:
    return {
        canonicalize_name(d.metadata["Name"]): d.version
        for d in distributions()
        if canonicalize_name(d.metadata["Name"]) != "viewer-slam"
    }


def test_every_installed_distribution_is_the_locked_version_and_nothing_else_is_installed():
    assert installed() == locked()


def test_every_entry_of_the_lock_is_an_exact_pin_with_hashes():
    entries = re.split(r"\n(?=\S)", LOCK.read_text().strip())
    assert len(entries) > 100
    for entry in entries:
        requirement = Requirement(entry.splitlines()[0].rstrip(" \\"))
        assert [specifier.operator for specifier in requirement.specifier] == ["=="], entry
        assert "--hash=sha256:" in entry, entry

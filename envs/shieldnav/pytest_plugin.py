"""The shieldnav pytest plugin (entry point ``pytest11``, on once shieldnav is installed).

Fixtures:

- ``shieldnav_env``: a factory ``make(env_id, **kwargs)`` of environments, closed at teardown.
- ``shieldnav_runner``: :func:`shieldnav.testing.run_episodes` with the run's options
  (``--shieldnav-workers``, ``--shieldnav-gif-dir``); its summaries carry the GIF folder, so the
  assertion helpers write the GIF of a failing episode there.

Options: ``--shieldnav-gif-dir DIR`` (GIFs of failing episodes), ``--shieldnav-workers N``
(processes per ``run_episodes`` call; default: the CPUs available, 1 under pytest-xdist). At the end of the run a
line reports the episodes run and how many had a contact or a deadlock. Works with
pytest-xdist: every test records its counts in its report, and the controller adds them up.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Iterator

import pytest

_EPISODES = "shieldnav_episodes"
_CONTACTS = "shieldnav_contact_episodes"
_DEADLOCKS = "shieldnav_deadlock_episodes"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("shieldnav", "shieldnav episode checks")
    group.addoption("--shieldnav-gif-dir", default=None, metavar="DIR", help="write a GIF of each failing episode check into DIR")
    group.addoption("--shieldnav-workers", type=int, default=None, metavar="N", help="processes per run_episodes call (default: the CPUs available; 1 under pytest-xdist)")


class _Totals:
    """The run's episode counts, from the tests' reports (on the xdist controller, its workers')."""

    def __init__(self) -> None:
        self.counts = {_EPISODES: 0, _CONTACTS: 0, _DEADLOCKS: 0}

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        # the teardown report carries every property the test recorded
        if report.when == "teardown":
            for key, value in report.user_properties:
                if key in self.counts:
                    self.counts[key] += int(value)

    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        c = self.counts
        if c[_EPISODES]:
            terminalreporter.write_line(f"shieldnav: {c[_EPISODES]} episodes run, {c[_CONTACTS]} with a contact, {c[_DEADLOCKS]} with a deadlock")


def pytest_configure(config: pytest.Config) -> None:
    config.pluginmanager.register(_Totals(), "shieldnav-totals")


@pytest.fixture
def shieldnav_env() -> Iterator[Callable[..., Any]]:
    """``make(env_id, **kwargs)``: ``gymnasium.make`` of a shieldnav id (``"ConstrictedPassage-v0"``
    or ``"shieldnav/ConstrictedPassage-v0"``) or of a ROS map (``.yaml``) or scenario (``.json``)
    file; every env made is closed at teardown."""
    from shieldnav.testing import make_env

    made: list[Any] = []

    def make(env_id: str, **kwargs: Any) -> Any:
        env = make_env(env_id, **kwargs)
        made.append(env)
        return env

    yield make
    for env in made:
        env.close()


@pytest.fixture
def shieldnav_runner(request: pytest.FixtureRequest) -> Callable[..., Any]:
    """``run(policy, env_ids, seeds, **kwargs)``: :func:`shieldnav.testing.run_episodes` with
    ``--shieldnav-workers`` and ``--shieldnav-gif-dir`` as defaults."""
    from shieldnav.testing import run_episodes

    options = request.config.option
    node = request.node

    def run(policy: Any, env_ids: Any, seeds: Any, **kwargs: Any) -> Any:
        workers = getattr(options, "shieldnav_workers", None)
        if workers is None and os.environ.get("PYTEST_XDIST_WORKER"):
            workers = 1  # pytest-xdist already runs a process per CPU
        kwargs.setdefault("workers", workers)
        kwargs.setdefault("gif_dir", getattr(options, "shieldnav_gif_dir", None))
        table = run_episodes(policy, env_ids, seeds, **kwargs)
        node.user_properties.append((_EPISODES, len(table)))
        node.user_properties.append((_CONTACTS, sum(r.first_contact_step is not None for r in table)))
        node.user_properties.append((_DEADLOCKS, sum(r.deadlock for r in table)))
        return table

    return run

"""The README's Python blocks run as written (a user copies them), and the functions it links are defined where it says."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_the_readme_has_python_blocks():
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("k", range(len(BLOCKS)))
def test_readme_block_runs(k):
    namespace: dict = {}
    exec(compile(BLOCKS[k], f"README.md python block {k + 1}", "exec"), namespace)
    if "out" in namespace:  # the shield's block: a point 1 m ahead slows the robot down
        assert namespace["out"].num_points == 3 and namespace["out"].u[0] < 1.0
        assert namespace["out3"].num_points == 1 and namespace["out3"].u.shape == (3,)
    if "brk" in namespace:  # the braking shield's block: full speed, the nose 0.65 m from a wall, brakes
        assert namespace["brk"].braked and not namespace["brk"].u.any()
    if "agent" in namespace:  # the scripted agent's episode of Scenario 1 ends without contact
        episode = namespace["info"]["shieldnav_episode"]
        assert episode["collisions"] == 0 and episode["steps"] > 100, episode
    if "vec" in namespace:
        assert namespace["obs"].shape[0] == 64
        namespace["vec"].close()


def test_every_function_the_readme_links_is_defined_in_the_linked_file():
    root = Path(__file__).resolve().parent.parent
    links = re.findall(r"\[`([A-Za-z_:]+)`\]\(([^)#]+\.rs)\)", (root / "README.md").read_text())
    assert len(links) >= 8
    for name, path in links:
        source = (root / path).read_text()
        assert re.search(rf"\bfn {name.split('::')[-1]}\b", source), f"README links {name} to {path}, which does not define it"

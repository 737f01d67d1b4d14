"""docs/skill-api.md is generated from the docstrings, is not stale, and is complete: every
public member of `Context` and `Skill` has a docstring and a row saying where it may be used
and what it costs."""

from __future__ import annotations

import functools

import pytest
from orchestrator.skills import Skill

from orchestrator.engine.context import Context
from orchestrator.engine.skill_api import (
    PAGE,
    SECTIONS,
    member_doc,
    public_members,
    skill_api,
)


@pytest.fixture(autouse=True, scope="module")
def _parse_each_class_once():
    """`member_doc` parses its class's source module for every member it is asked about
    (`inspect.getsource` reads and parses the whole file): ~100 members, seconds per test.
    The source does not change during the run, so each class is parsed once here."""
    from orchestrator.engine import skill_api as module

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(module, "_attribute_docs", functools.cache(module._attribute_docs))
        yield


def test_the_page_is_not_stale():
    assert PAGE.read_text() == skill_api(), (
        "docs/skill-api.md is stale: run `python -m orchestrator.engine.skill_api`"
    )


@pytest.mark.parametrize("cls", [Context, Skill], ids=lambda c: c.__name__)
def test_every_public_member_has_a_docstring_and_a_row(cls):
    listed = [m.name for s in SECTIONS if s.cls is cls for m in s.members]
    assert len(listed) == len(set(listed)), "a member is listed twice"
    members = public_members(cls)
    assert members - set(listed) == set(), "public members the page does not list"
    assert set(listed) - members == set(), "rows for members that do not exist"
    assert sorted(n for n in members if not member_doc(cls, n).strip()) == []
    page = PAGE.read_text()
    prefix = "ctx." if cls is Context else "self."
    for name in members:
        assert f"| `{prefix}{name}` |" in page, name


def test_every_row_has_its_docstring():
    page = PAGE.read_text()
    for section in SECTIONS:
        for m in section.members:
            doc = member_doc(section.cls, m.name)
            assert doc.strip(), f"{section.cls.__name__}.{m.name} has no docstring"
            assert " ".join(doc.split()).replace("|", "\\|") in page


class _Grown(Context):
    """A Context that grew members without docstrings (the check must see them)."""

    def __init__(self) -> None:  # never called: only its source is read
        self.fresh = 1
        self.documented = 2
        """Has one."""

    @property
    def bare(self) -> int:
        return 0


def test_the_completeness_check_sees_a_member_without_a_docstring():
    members = public_members(_Grown)
    assert {"fresh", "documented", "bare"} <= members
    assert member_doc(_Grown, "fresh") == "" and member_doc(_Grown, "bare") == ""
    assert member_doc(_Grown, "documented") == "Has one."


def test_every_skill_facing_type_has_a_section_listing_all_its_members():
    # what `ctx` hands a skill beyond itself: the IK solver, poses, object handles, the
    # blackboard (a pose's pydantic methods are pydantic's, documented there)
    from orchestrator.skills.ik import IKSolver
    from pydantic import BaseModel

    from orchestrator.engine.blackboard import Blackboard
    from orchestrator.world.pose import Pose
    from orchestrator.world.world import ObjectHandle

    page = PAGE.read_text()
    for cls in (IKSolver, Pose, ObjectHandle, Blackboard):
        sections = [s for s in SECTIONS if s.cls is cls]
        assert len(sections) == 1, cls.__name__
        listed = {m.name for m in sections[0].members}
        members = public_members(cls) - set(dir(BaseModel))
        assert members - listed == set(), (cls.__name__, "not on the page")
        for name in listed:
            assert f"| `{sections[0].prefix}{name}` |" in page
    assert "| `ctx.start_pose` |" in page and "## `CheckParams`" in page

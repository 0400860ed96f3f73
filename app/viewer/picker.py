"""The robot picker at the top of the page: a group, a search field and the list of the robots that
match (``RobotInfo`` of app/viewer/server.py). Picking a robot calls ``on_pick(name)``; a group or a
search only narrows the list."""
from __future__ import annotations

from typing import Callable, List

GROUP_LABELS = {"exam": "Exam robots", "throwing": "Throwing arm", "catching": "Catching arm",
                "other": "Other robots"}
ALL_GROUPS = "All robots"


class RobotPicker:
    """The picker's three widgets (at ``order``) over ``catalog``; ``current()`` is the name of
    the robot shown, ``lock`` the session's (the list and the robot shown change together)."""

    def __init__(self, gui, catalog: List, order: float, current: Callable[[], str], on_pick: Callable[[str], None],
                 lock):
        self.catalog, self.current, self.on_pick, self.lock = catalog, current, on_pick, lock
        groups = [g for g in GROUP_LABELS if any(info.group == g for info in catalog)]
        self.group_options = {ALL_GROUPS: "", **{GROUP_LABELS[g]: g for g in groups}}
        self.group = gui.add_dropdown(
            "Group", list(self.group_options), initial_value=ALL_GROUPS,
            order=order, hint="Exam robots, the throwing arm of the VHC thesis, the catching arm")
        self.find = gui.add_text("Find robot", "", order=order + 0.2,
                                 hint="words of the name, the family (RP, 3R, PRP ...) or the exam date "
                                      "(2004-03-25, 2019): the list below keeps the robots that match")
        options = self.options()
        self.robots = gui.add_dropdown("Robot", options, initial_value=options[0], order=order + 0.5,
                                       hint="Pick a robot: scene, sliders and panels follow")

    def listen(self) -> None:
        """Follow the student's choices (once the page can load a robot)."""
        for handle in (self.group, self.find):        # a group or a search narrows the list; it loads nothing
            handle.on_update(lambda event: event.client is not None and self.refresh())
        self.robots.on_update(lambda event: event.client is not None and self._picked())

    def visible(self) -> List:
        group = self.group_options.get(self.group.value, "")
        query = self.find.value
        return [i for i in self.catalog if (not group or i.group == group) and i.matches(query)]

    def options(self) -> List[str]:
        """The robot list: a first line that loads nothing (how many match), then the robots."""
        shown = self.visible()
        head = f"— {len(shown)} robot{'' if len(shown) == 1 else 's'}: pick one —" if shown else "— no robot matches —"
        return [head] + [self.option_of(i) for i in shown]

    def option_of(self, info) -> str:
        """A robot's line in the list: family and title (and its name when titles repeat)."""
        same = [i for i in self.catalog if i.title == info.title]
        title = info.title if len(same) == 1 else f"{info.title} ({info.name})"
        return f"{info.family} · {title}" if info.family else title

    def refresh(self) -> None:
        """The robot list after a group choice or a search; the robot shown stays loaded."""
        with self.lock:
            options = self.options()
            name = self.current()
            shown = next((self.option_of(i) for i in self.catalog if i.name == name), None)
            self.robots.options = options
            self.robots.value = shown if shown in options else options[0]

    def _picked(self) -> None:
        option = self.robots.value
        info = next((i for i in self.catalog if self.option_of(i) == option), None)
        if info is not None and info.name != self.current():
            self.on_pick(info.name)

    def show(self, name: str) -> None:
        """Select the robot ``name`` in the list (listing all robots again when it was filtered out)."""
        options = self.options()
        info = next((i for i in self.catalog if i.name == name), None)
        if info is not None and self.option_of(info) not in options:      # shown again: list all
            self.group.value = ALL_GROUPS
            self.find.value = ""
            options = self.options()
        self.robots.options = options
        if info is not None:
            self.robots.value = self.option_of(info)

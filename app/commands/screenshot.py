"""``python -m app screenshot``: a 1280x720 picture of the page in headless Chromium."""
NAME = "screenshot"
HELP = "save a picture of the page (headless Chromium)"
DESCRIPTION = ("Start the lab in-process, open it in headless Chromium (Debian's /usr/bin/chromium), "
               "select a robot and a panel, and save a PNG. --all-docs regenerates docs/screenshots/ (the list "
               "below, then every panel module's save_doc_screenshots(out_dir)).")

#: the pictures in docs/screenshots/: (file, robot, panel, coordinates or None, step index or None)
DOC_SHOTS = [
    ("rp_2004_03_25_model.png", "rp_2004_03_25", "Model", [0.5, 0.25], None),
    ("spatial_3r_model.png", ("spatial_3r", "viewer_demo_spatial_3r"), "Model", None, None),
    ("throwing_arm_model.png", "throwing_arm", "Model", None, None),
    ("planar_2r_steps.png", "planar_2r", "Steps", [0.6, 0.9], 3),
]


def add_arguments(p):
    p.add_argument("--robot", help="robot name (see `python -m app robots`)")
    p.add_argument("--panel", default=None, help="tab to open, e.g. model, steps (case-insensitive)")
    p.add_argument("--q", default=None, help="coordinates, comma-separated, e.g. 0.3,-0.6")
    p.add_argument("--step", type=int, default=None, help="with --panel steps: the step to show (1-based)")
    p.add_argument("--out", default=None, help="PNG file to write")
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=720)
    p.add_argument("--all-docs", action="store_true", help="regenerate every picture in docs/screenshots/")


def run(args) -> int:
    from pathlib import Path

    from app.core.errors import UserError
    from app.core.robot import list_robot_names

    if args.all_docs:
        return _all_docs()
    if not args.robot or not args.out:
        raise UserError("give --robot NAME and --out FILE.png (or --all-docs)")
    if args.robot not in list_robot_names() and not Path(args.robot).exists():
        raise UserError(f"unknown robot '{args.robot}' (`python -m app robots` lists them)")
    q = None
    if args.q:
        try:
            q = [float(v) for v in args.q.split(",")]
        except ValueError:
            raise UserError(f"--q: expected comma-separated numbers, got '{args.q}'") from None
    path = shoot(args.robot, args.out, args.panel, q, (args.step - 1) if args.step else None,
                 args.width, args.height)
    print(path)
    return 0


def _panel_title(name):
    """The tab title matching ``name`` case-insensitively (UserError when there is none)."""
    from app.core.errors import UserError
    from app.panels import discover_panels
    if name is None:
        return None
    titles = [p.title for p in discover_panels()]
    for title in titles:
        if title.lower() == name.lower():
            return title
    raise UserError(f"unknown panel '{name}' (panels: {', '.join(titles)})")


def shoot(robot, out, panel=None, q=None, step=None, width=1280, height=720, lab=None, browser=None):
    """One picture; ``q`` sets the coordinates, ``step`` opens a derivation step (0-based)."""
    from app.core.errors import UserError
    from app.viewer.screenshot import capture

    title = _panel_title(panel)

    def setup(session):
        if q is not None:
            if len(q) != session.robot.n:
                raise UserError(f"--q: {session.robot_name} has {session.robot.n} coordinates, got {len(q)}")
            session.set_q(q)
        if step is not None:
            count = len(session.dynamics.steps)
            if not 0 <= step < count:
                raise UserError(f"--step: {session.robot_name} has {count} steps")
            session.state["steps"]["show"](step)

    return capture(robot, out, panel=title, setup=setup, width=width, height=height, lab=lab, browser=browser)


def _all_docs() -> int:
    from pathlib import Path

    from app.core.robot import list_robot_names
    from app.viewer.screenshot import Browser
    from app.viewer.server import LabServer

    out_dir = Path(__file__).resolve().parents[2] / "docs" / "screenshots"
    names = list_robot_names()
    lab = LabServer(port=0, verbose=False)
    try:
        with Browser() as browser:
            for filename, robot, panel, q, step in DOC_SHOTS:
                if isinstance(robot, tuple):    # the first robot whose name starts with one of these
                    robot = next((n for prefix in robot for n in names if n.startswith(prefix)), None)
                    if robot is None:
                        print(f"skipped {filename}: no such robot yet")
                        continue
                path = shoot(robot, out_dir / filename, panel, q, step, lab=lab, browser=browser)
                print(f"{path}  ({robot})")
    finally:
        lab.stop()
    from app.viewer import sheets
    for module in _panel_modules_with_pictures() + [sheets]:     # pictures that need their own set-up
        for path in module.save_doc_screenshots(out_dir):
            print(f"{path}  ({module.__name__})")
    return 0


def _panel_modules_with_pictures():
    """Panel modules that define ``save_doc_screenshots(out_dir)`` (their own docs pictures)."""
    import importlib

    from app.panels import discover_panels
    modules = [importlib.import_module(f"app.panels.{spec.name}") for spec in discover_panels()]
    return [m for m in modules if callable(getattr(m, "save_doc_screenshots", None))]

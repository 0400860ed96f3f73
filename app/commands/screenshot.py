"""``python -m app screenshot``: a 1280x720 picture of the page in headless Chromium."""
NAME = "screenshot"
HELP = "save a picture of the page (headless Chromium)"
DESCRIPTION = ("Start the lab in-process, open it in headless Chromium (Debian's /usr/bin/chromium), "
               "select a robot and a panel, and save a PNG. --all-docs regenerates the pictures of the page in "
               "docs/screenshots/ (app/viewer/doc_pictures.py) and the exam sheet's (app/viewer/sheets.py).")

def add_arguments(p):
    p.add_argument("--robot", help="robot name (see `python -m app robots`)")
    p.add_argument("--panel", default=None, help="tab to open, e.g. model, steps (case-insensitive)")
    p.add_argument("--q", default=None, help="coordinates, comma-separated, e.g. 0.3,-0.6")
    p.add_argument("--step", type=int, default=None, help="with --panel steps: the step to show (1-based)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a parameter of the robot, e.g. m1=12 or l1=3/2 (repeatable)")
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
    params = {}
    if args.set:              # checked before a browser starts, by the rule of the page's fields
        from app.commands._options import assignments
        from app.core.robot import load_robot
        from app.viewer.fields import parse_parameter
        robot = load_robot(args.robot)
        params = {name: parse_parameter(robot, name, text) for name, text in assignments(args.set).items()}
    q = None
    if args.q:
        try:
            q = [float(v) for v in args.q.split(",")]
        except ValueError:
            raise UserError(f"--q: expected comma-separated numbers, got '{args.q}'") from None
    path = shoot(args.robot, args.out, args.panel, q, (args.step - 1) if args.step else None,
                 args.width, args.height, params=params)
    print(path)
    return 0


def _panel_title(name):
    """The tab title matching ``name`` case-insensitively (UserError when there is none)."""
    from app.core.errors import UserError
    from app.panels import registry
    if name is None:
        return None
    titles = [p.title for p in registry().specs]
    for title in titles:
        if title.lower() == name.lower():
            return title
    raise UserError(f"unknown panel '{name}' (panels: {', '.join(titles)})")


def shoot(robot, out, panel=None, q=None, step=None, width=1280, height=720, lab=None, browser=None,
          params=None):
    """One picture; ``q`` sets the coordinates, ``step`` opens a derivation step (0-based),
    ``params`` ({name: value}) changes parameters of the robot; a lab server (with the panels,
    ``serve.lab_server``) is started for it unless ``lab`` is given."""
    from app.commands.serve import lab_server
    from app.core.errors import UserError
    from app.viewer.screenshot import capture, wait_until

    title = _panel_title(panel)

    def setup(session):
        if params:
            session.set_parameters(params)
            wait_until(lambda: all(session.numeric.values[k] == v for k, v in params.items()), 30,
                       "the parameters in the model")
        if q is not None:
            if len(q) != session.robot.n:
                raise UserError(f"--q: {session.robot_name} has {session.robot.n} coordinates, got {len(q)}")
            session.set_q(q)
        if step is not None:
            count = len(session.dynamics.steps)
            if not 0 <= step < count:
                raise UserError(f"--step: {session.robot_name} has {count} steps")
            session.open_panel("steps")["show"](step)

    own_lab = lab is None
    lab = lab or lab_server(port=0, robot=robot)
    try:
        return capture(robot, out, panel=title, setup=setup, width=width, height=height, lab=lab, browser=browser)
    finally:
        if own_lab:
            lab.stop()


def _all_docs() -> int:
    from app.commands.serve import lab_server
    from app.viewer import doc_pictures, sheets
    from app.viewer.screenshot import Browser

    lab = lab_server(port=0)
    try:
        with Browser() as browser:
            doc_pictures.save_all(lab, shoot, doc_pictures.DOCS_DIR, browser)
    finally:
        lab.stop()
    for path in sheets.save_doc_screenshots(doc_pictures.DOCS_DIR):     # pictures of the exam sheet
        print(f"{path}  (sheets)")
    return 0

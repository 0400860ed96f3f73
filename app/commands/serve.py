"""``python -m app serve``: start the web viewer (the default command)."""
NAME = "serve"
HELP = "start the web viewer (default command)"
DESCRIPTION = ("Start the Robotics II Lab page. Every browser tab gets its own robot, parameters, "
               "camera and panels. Binds 127.0.0.1 unless --host says otherwise.")


def add_arguments(p):
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; 0.0.0.0 for the LAN)")
    p.add_argument("--port", type=int, default=8080, help="port (default 8080; 0 picks a free one)")
    p.add_argument("--robot", default=None, help="robot shown first (default planar_2r)")


#: seconds a thread may hold the interpreter lock while another waits (Python's default: 0.005). The
#: server's threads are many short callbacks and a few that build panels; at 1 ms a slider's round
#: trip waits less behind them (benchmarks/load.py, loaded p95: 100-117 ms against 120-204 ms).
SWITCH_INTERVAL = 0.001


def run(args) -> int:
    import sys
    import time

    from app.panels.exercises import shipped_exercises

    sys.setswitchinterval(SWITCH_INTERVAL)
    lab = lab_server(host=args.host, port=args.port, robot=args.robot)
    # the picker's and the Exercises tab's lists, the first robot; then, at idle, every other one
    lab.warm_up(shipped_exercises, every_robot=True)
    print(f"Robotics II Lab: open {lab.url} in a browser (Ctrl+C stops)", flush=True)
    if lab.policy.token:
        print(f"Other machines: http://<this machine's address>:{lab.viser.get_port()}/{lab.policy.token}/ "
              "(the token is new at every start; without it the server refuses)", flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        lab.stop()
    return 0


def lab_server(**options):
    """A ``LabServer`` (app/viewer/server.py) with the page's panels (``app.panels.registry()``):
    what ``serve``, ``screenshot``, the tests and the benchmarks start. ``options`` as
    ``LabServer``'s (``verbose`` False unless given)."""
    from app.panels import registry
    from app.viewer.server import LabServer
    return LabServer(**{"verbose": False, **options}, panels=registry())

"""The web viewer: a viser server (``server.LabServer``) with one ``session.Session`` per browser
tab, the robot's 3D scene (``scene_view``), typeset math (``mathml``) and headless screenshots
(``screenshot``). Panels live in app/panels; docs/panels.md explains how to write one."""

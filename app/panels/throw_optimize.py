"""The Throw studio's *Optimize* tab: run the throw optimizer (app/core/throw/optimize.py) with an
objective, an evaluation budget and a seed, load its best throw, and confirm a throw in the full
3-DOF dynamics (app/core/throw/simulation.py), all off the event thread under a progress bar.
"""
from __future__ import annotations

import threading
import time

from app.core.errors import UserError
from app.core.throw.config import ThrowConfig, ThrowSpec
from app.core.throw.optimize import DEFAULT_EVALUATIONS
from app.core.throw.study import optimize_and_verify, verify_throw
from app.viewer import in_worker

from .throw_plots import StudioTab, status_html, verification_html

OBJECTIVES = {"thesis convention (θ̇ along ψ)": "thesis", "true ball velocity (J q̇)": "physical"}


class OptimizeTab(StudioTab):
    """Widgets of the *Optimize* tab; ``studio`` is the ThrowStudio (its ``view`` is the throw on display)."""

    def __init__(self, studio):
        super().__init__(studio, "Maximize the distance from the base over the control points (degree 6), θb, θe, "
                                 "ψ and k under every limit of Table A.2 (and q1 ≥ π/6 of eq. 4.5), then confirm the "
                                 "best throw in the full 3-DOF dynamics.")
        gui = studio.gui
        self.objective = gui.add_dropdown("Objective", list(OBJECTIVES), initial_value=list(OBJECTIVES)[0],
                                          hint="which release velocity the distance uses")
        self.budget = gui.add_slider("Budget [evaluations]", min=2000, max=60000, step=1000,
                                     initial_value=DEFAULT_EVALUATIONS,
                                     hint="throw evaluations the search may spend (the same seed gives the same "
                                          "throw on any machine); it also stops near the speed-limit bound")
        self.seed = gui.add_number("Seed", 0, min=0, max=10 ** 6, step=1, hint="random start of the global stage")
        self.optimize_button = gui.add_button("Optimize", hint="run the optimizer (off the event thread)")
        self.opt_progress = gui.add_progress_bar(0.0, visible=False, animated=True)
        self.opt_status = gui.add_html("")
        self.verify_button = gui.add_button("Verify in full dynamics",
                                            hint="simulate the complete arm (wrist free) with the VHC torques "
                                                 "and with a tracking controller")
        self.verification = gui.add_html("")
        self._optimizing = False
        self.optimize_button.on_click(lambda _e: studio._guarded(self.optimize))
        self.verify_button.on_click(lambda _e: studio._guarded(self.verify))

    def optimize(self, wait: bool = False):
        """Run the optimizer with the tab's settings, then verify the best throw in the full dynamics
        and load it (in the background; ``wait`` blocks until done)."""
        if self._optimizing:
            raise UserError("the optimizer is already running")
        studio = self.studio
        objective = OBJECTIVES[self.objective.value]
        budget = int(self.budget.value)
        seed = int(self.seed.value)
        arm = studio.arm()
        self._optimizing = True
        self.optimize_button.disabled = True
        self.opt_progress.value = 0.0
        self.opt_progress.visible = True
        self.opt_status.content = status_html("starting ...")
        started = time.monotonic()
        shown = {"fraction": 0.0, "message": "starting"}
        done_event = threading.Event()

        def tick():     # the bar also advances with the clock between the optimizer's reports
            while not done_event.wait(0.5):
                if not studio._alive():
                    return
                clock = min(0.85, 0.85 * (time.monotonic() - started) / (budget / 2000.0))
                if clock > shown["fraction"] and shown["fraction"] < 0.85:
                    self.opt_progress.value = 100 * clock

        def work(progress):
            def report(fraction, message):
                shown.update(fraction=0.85 * fraction, message=message)
                progress(0.85 * fraction, message)
                if studio._alive():
                    self.opt_progress.value = max(self.opt_progress.value, 100 * 0.85 * fraction)
                    self.opt_status.content = status_html(message)
            threading.Thread(target=tick, daemon=True).start()
            try:       # in a worker process of the server (app/viewer/worker.py)
                return in_worker(optimize_and_verify, arm.robot, arm.values, objective, seed, budget, progress=report)
            finally:
                done_event.set()
                self._optimizing = False
                if studio._alive():
                    self.optimize_button.disabled = False
                    self.opt_progress.visible = False

        def done(out):
            result, sims = out
            convention = "θ̇ along ψ" if result.objective == "thesis" else "J q̇"
            title = f"Optimized throw, {convention}, seed {seed}"
            notes = (f"{result.distance_from_base:.4f} m from the base ({convention}) after {result.elapsed:.1f} s, "
                     f"{result.evaluations} throw evaluations; the speed limits alone allow "
                     f"{result.bound.distance_from_base:.4f} m.")
            self.opt_status.content = status_html(notes, done=True)
            studio.load_config(ThrowConfig(result.spec, {}, title, notes, {}, "optimizer"))
            self._show_verification(sims, result.spec)

        return studio.background(work, "Optimizing the throw", self.opt_status, done, wait)

    def verify(self, wait: bool = False):
        """Simulate the throw on display in the full dynamics (both controllers) and show the drifts."""
        studio = self.studio
        view = self.throw_on_display("verify")
        self.verify_button.disabled = True
        self.verification.content = status_html("simulating the full arm ...")
        arm = view.throw.arm

        def work(progress):
            try:       # in a worker process of the server (app/viewer/worker.py)
                return in_worker(verify_throw, arm.robot, arm.values, view.spec, progress=progress)
            finally:
                if studio._alive():
                    self.verify_button.disabled = False

        return studio.background(work, "Full-dynamics simulation", self.verification,
                                 lambda sims: self._show_verification(sims, view.spec), wait)

    def _show_verification(self, sims, spec: ThrowSpec) -> None:
        studio = self.studio
        if not studio._alive():
            return
        view = studio.view
        if view is None or view.spec != spec:
            try:
                view = studio.evaluate(spec)
            except UserError:
                return
        self.verification.content = verification_html(sims, view)

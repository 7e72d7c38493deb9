"""What every DeformRT operator shares: a refusal reported in one place, and long work that runs
on a worker thread in the UI (the main thread polls it on a timer, shows progress, stays
responsive, and Esc stops it) and blocks headless callers. Only the main thread touches bpy data:
``prepare`` reads the scene, ``work`` is plain numpy, ``finish`` writes back. Work that needs bpy
at every step (frames to resolve one by one) runs in steps on the main thread instead, one per
timer tick in the UI (SteppedOperator)."""

import threading
import time


class DeformRTOperator:
    """Refusals: core and the services raise ValueError or RuntimeError with a sentence a user can
    act on; the operator reports it and changes nothing. Before it runs, ``unavailable(context)``
    says why it cannot (greyed out, the sentence as the tooltip), or None."""

    @classmethod
    def poll(cls, context):
        why = cls.unavailable(context)
        if why:
            cls.poll_message_set(why)
        return not why

    @classmethod
    def unavailable(cls, context) -> str | None:
        return None

    def fail(self, exc) -> set:
        self.report({"ERROR"}, str(exc))
        return {"CANCELLED"}


class BackgroundOperator(DeformRTOperator):
    """An operator whose work can take long. A subclass defines

    - ``prepare(context)`` (main thread): read and check what the work needs; raise to refuse;
    - ``work(job, progress, stop)`` (a worker thread in the UI, no bpy): the result; it calls
      ``progress(done, total, **shown)`` as it goes and, where it can stop early, ends soon after
      ``stop()`` turns true;
    - ``finish(context, job, result)`` (main thread): write and report; returns the operator's set;

    and sets ``status`` (shown while it runs) and ``keeps_partial``: whether Esc lets the work end
    with what it has (an optimiser's best so far) or drops it at once (nothing written yet)."""

    status = "DeformRT: working (Esc to cancel)"
    keeps_partial = False
    interval = 0.1
    cancelled_message = "Cancelled: nothing was changed"

    def prepare(self, context):
        raise NotImplementedError

    def work(self, job, progress, stop):
        raise NotImplementedError

    def finish(self, context, job, result) -> set:
        raise NotImplementedError

    def status_text(self, state) -> str:
        """What the status bar says while the work runs (``state``: done, total, what progress showed)."""
        return self.status

    def execute(self, context):
        wm = context.window_manager
        try:
            job = self.prepare(context)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        wm.progress_begin(0, 100)
        try:
            result = self.work(job, lambda done, total, **_: wm.progress_update(int(100 * done / max(total, 1))),
                               lambda: False)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        finally:
            wm.progress_end()
        return self.finish(context, job, result)

    def invoke(self, context, _event):
        if context.window is None:  # headless: block, as a script expects
            return self.execute(context)
        try:
            self._job = self.prepare(context)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        self._state = {"done": 0, "total": 0, "stop": False, "started": time.perf_counter()}
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(self.interval, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        context.workspace.status_text_set(self.status)
        return {"RUNNING_MODAL"}

    def _run(self):
        state = self._state

        def progress(done, total, **shown):
            state.update(done=done, total=total, **shown)

        try:
            state["result"] = self.work(self._job, progress, lambda: state["stop"])
        except (ValueError, RuntimeError) as exc:
            state["error"] = exc

    def _end(self, context):
        """Undo what invoke set up (a dropped worker is left to end on its own)."""
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)

    def modal(self, context, event):
        state = self._state
        if event.type == "ESC":
            if not self.keeps_partial:
                self._end(context)  # the worker's result is dropped when it ends: nothing was written
                self.report({"WARNING"}, self.cancelled_message)
                return {"CANCELLED"}
            state["stop"] = True  # the work ends soon and keeps what it has
        if event.type != "TIMER":
            return {"RUNNING_MODAL"} if event.type == "ESC" else {"PASS_THROUGH"}
        if self._thread.is_alive():
            wm = context.window_manager
            if state["total"]:
                wm.progress_update(int(100 * state["done"] / state["total"]))
            else:  # no count to show: the seconds go round
                wm.progress_update(int(time.perf_counter() - state["started"]) % 100)
            context.workspace.status_text_set(self.status_text(state))
            return {"RUNNING_MODAL"}
        self._end(context)
        if "error" in state:
            return self.fail(state["error"])
        return self.finish(context, self._job, state["result"])


class SteppedOperator(DeformRTOperator):
    """An operator whose long work must touch bpy, so it runs on the main thread a step at a time:
    one step per timer tick in the UI (the status bar shows it, Esc stops it between steps), all
    steps in a row headless. A subclass defines ``start(context)``: a job with ``advance()`` (one
    step; False when none is left or one failed), ``done`` and ``total`` (steps), and
    ``end(cancelled)`` (``cancelled``: None, or what stopped it), which finishes and returns
    (succeeded, the message to report); raise ValueError or RuntimeError in ``start`` to refuse.
    ``status`` may name the total as {total}."""

    status = "DeformRT: working (Esc to stop)"

    def start(self, context):
        raise NotImplementedError

    def execute(self, context):
        try:
            self._stepped = self.start(context)
        except (ValueError, RuntimeError) as exc:
            return self.fail(exc)
        if context.window is None or getattr(self, "headless", False):
            while self._stepped.advance():
                pass
            return self._stepped_end(None)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.001, window=context.window)
        wm.progress_begin(0, self._stepped.total)
        wm.modal_handler_add(self)
        context.workspace.status_text_set(self.status.format(total=self._stepped.total))
        return {"RUNNING_MODAL"}

    def _stepped_end(self, cancelled) -> set:
        ok, message = self._stepped.end(cancelled)
        self.report({"INFO"} if ok else {"ERROR"}, message)
        return {"FINISHED"} if ok else {"CANCELLED"}

    def modal(self, context, event):
        if event.type not in ("TIMER", "ESC"):
            return {"RUNNING_MODAL"}  # no frame changes or edits under the work
        more = event.type == "TIMER" and self._stepped.advance()
        wm = context.window_manager
        if more:
            wm.progress_update(self._stepped.done)
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        return self._stepped_end("Esc" if event.type == "ESC" else None)

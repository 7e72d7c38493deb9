"""Long operator work on a worker thread: the main thread polls it on a timer, shows progress
and stays responsive (only the main thread may touch bpy data)."""

import threading


def start(op, context, work, status, interval=0.1):
    """Run ``work()`` on a thread and make ``op`` modal with a timer and a progress bar."""
    op._thread = threading.Thread(target=work, daemon=True)
    op._thread.start()
    wm = context.window_manager
    op._timer = wm.event_timer_add(interval, window=context.window)
    wm.progress_begin(0, 100)
    wm.modal_handler_add(op)
    context.workspace.status_text_set(status)
    return {"RUNNING_MODAL"}


def finish(op, context):
    """Undo what ``start`` set up (the thread is left to end on its own)."""
    wm = context.window_manager
    wm.event_timer_remove(op._timer)
    wm.progress_end()
    context.workspace.status_text_set(None)

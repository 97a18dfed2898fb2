"""An nlobs observer as a python-control input/output system (``observer.to_control()``).

:func:`to_control` (python-control is an optional extra, ``pip install 'nlobs[control]'``) wraps an
observer of the one protocol whose state is an array as a ``control.NonlinearIOSystem`` with inputs
``[u, y]``, state ``z`` and outputs the estimate ``x̂``. It lives with the
:class:`~nlobs.observers.base.ToControl` mix-in that every observer inherits, in
:mod:`nlobs.observers.base` (where its full description is), and is importable from here as well.
"""

from __future__ import annotations

from nlobs.observers.base import to_control

__all__ = ["to_control"]

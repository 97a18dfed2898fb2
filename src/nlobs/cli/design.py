"""``nlobs design drift`` and ``nlobs design pinv``: the differential-geometric observers (seeds 002, 003)."""

from __future__ import annotations

from nlobs.cli.common import design_app  # noqa: F401  (commands are added below)

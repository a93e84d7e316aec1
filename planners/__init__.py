"""planners: decisions made with the belief (robust plans over P, informative probing actions).

Not built yet: it is the subject of a later issue. The package exists because the project layout
fixes it; it exports nothing.
"""
from __future__ import annotations

__all__: list[str] = []

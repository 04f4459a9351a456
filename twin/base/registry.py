"""One kind of registry for every extension point: robots, force models, effects, export formats, labs and
discrepancy families.

An extension point is a base class or protocol (what a part must give) plus a `Registry` of named parts. Adding a
part is one call, `REGISTRY.register(part)`, from the user's own code; nothing in the package changes. A registry
reads like the mapping it was before (`name in R`, `R[name]`, `R.values()`; a test may `monkeypatch.setitem` it), refuses a duplicate or reserved
name, and answers an unknown name with the registered ones (`R.get_named`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, MutableMapping
from typing import Generic, TypeVar

from twin.errors import InputError

T = TypeVar("T")


class Registry(MutableMapping[str, T], Generic[T]):
    """Named parts of one extension point, in registration order.

    Args:
        kind: What a part is, in words ("force model"), for messages.
        name_of: How a part names itself (default: its `name` attribute).
        reserved: Names no part may take (e.g. "auto").
        error: The `TwinError` an unknown name raises (default `InputError`).
    """

    def __init__(self, kind: str, name_of: Callable[[T], str] | None = None, reserved: tuple[str, ...] = (),
                 error: Callable[[str], Exception] = InputError) -> None:
        self.kind = kind
        self._name_of = name_of or (lambda part: str(part.name))  # type: ignore[attr-defined]
        self._reserved = reserved
        self._error = error
        self._parts: dict[str, T] = {}

    def register(self, part: T, *, replace: bool = False) -> T:
        """Add `part` under its name; returns it (so it can decorate).

        Raises:
            InputError: An empty or reserved name, or one already registered (unless `replace`).
        """
        name = self._name_of(part)
        if not name or name in self._reserved or (name in self._parts and not replace):
            raise InputError(f"{self.kind} name {name!r} is empty, reserved ({', '.join(self._reserved) or 'none'}) "
                             f"or already registered ({', '.join(self._parts)})")
        self._parts[name] = part
        return part

    def unregister(self, name: str) -> None:
        """Remove a part (a test's or a session's own); an unknown name is ignored."""
        self._parts.pop(name, None)

    def get_named(self, name: str) -> T:
        """The part `name`.

        Raises:
            The registry's error (`InputError` by default): unknown name, naming the registered ones.
        """
        if name not in self._parts:
            raise self._error(f"unknown {self.kind} {name!r}; registered: {sorted(self._parts)}")
        return self._parts[name]

    def __getitem__(self, name: str) -> T:
        return self._parts[name]

    def __setitem__(self, name: str, part: T) -> None:
        """Set a part directly (what `monkeypatch.setitem` does in a test); `register` checks the name."""
        self._parts[name] = part

    def __delitem__(self, name: str) -> None:
        del self._parts[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._parts)

    def __len__(self) -> int:
        return len(self._parts)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._parts)})"

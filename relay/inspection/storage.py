"""The inspection database on a thread of its own: opened and closed there, and each command's call to it failing
as the ``error`` its client gets, naming the database."""

from __future__ import annotations

import tempfile
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeVar

from ..errors import CommandRejected
from ..session.protocol import ErrorCode, RequestId
from ..station.work import Busy, WorkPool

if TYPE_CHECKING:
    from ..cli.options import Options
    from .store import Store

T = TypeVar("T")


class StoreRunner(Protocol):
    """Runs ``work`` on the store's thread; raises CommandRejected naming the database when it fails."""

    def __call__(self, work: Callable[[Store], T], request_id: RequestId | None = None) -> Awaitable[T]: ...


class Storage:
    """The store (None until :meth:`open`) behind its one thread (``WorkPool("store")``, with a bounded queue)."""

    def __init__(self, options: Options) -> None:
        self._options = options
        self.store: Store | None = None
        self._pool = WorkPool("store", workers=1, queue=256)
        self._temporary: tempfile.TemporaryDirectory[str] | None = None

    async def open(self) -> Store:
        """The database ``--database`` names, its images where ``--images`` says (by default beside it)."""
        from .store import Store, default_images

        database, images = self._options.database, self._options.images
        if database is None:  # library use and tests: a database of this run only
            self._temporary = tempfile.TemporaryDirectory(prefix="xr-relay-inspection-")
            database = str(Path(self._temporary.name) / "inspection.sqlite")
        if images is None:
            images = str(default_images(database))
        self.store = await self._pool.run(lambda: Store.open(database, Path(images)))
        return self.store

    async def run(self, work: Callable[[], T]) -> T:
        """``work()`` on the store's thread; its errors as they are."""
        return await self._pool.run(work)

    async def call(self, work: Callable[[Store], T], request_id: RequestId | None = None) -> T:
        """``work(store)`` for a client's command; a failure is the CommandRejected naming the database."""
        from .store import StoreError, UnknownRecord

        store = self.store
        if store is None:
            raise CommandRejected(ErrorCode.INTERNAL, "the inspection database is not open", request_id)
        try:
            return await self._pool.run(lambda: work(store))
        except UnknownRecord as exc:  # the client named something that is not there: its mistake, not the relay's
            raise CommandRejected(ErrorCode.BAD_REQUEST, str(exc), request_id) from None
        except Busy as exc:  # a bounded queue that is full: nothing was done, the client may send it again
            raise CommandRejected(ErrorCode.BUSY, f"inspection database: {exc}", request_id) from None
        except StoreError as exc:
            raise CommandRejected(ErrorCode.INTERNAL, f"inspection database: {exc}", request_id) from None

    async def close(self) -> None:
        store = self.store
        if store is not None:
            await self._pool.run(store.close)
        self._pool.shutdown()
        if self._temporary is not None:
            self._temporary.cleanup()

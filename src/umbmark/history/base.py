"""What every history backend shares: the base class of the backends (:class:`_Backend`: adding a
record, once per recording, and reading records back, a damaged one skipped), and, from the
modules it is made of, every name of the history's shared code:

* :mod:`umbmark.history.address`: where the database is, and its URL's secrets masked;
* :mod:`umbmark.history.records`: the record type, the kinds, the errors, a robot's name;
* :mod:`umbmark.history.schema`: the schema and its migrations, a row made and read back;
* :mod:`umbmark.history.same_recording`: the guard of one recording recorded once;
* :mod:`umbmark.history.parameters`: the parameters of an analysis, and a record's export.

Imports only the standard library, :mod:`umbmark._files` (a file's hash) and those modules (which
import only the standard library, :mod:`umbmark.errors` and :mod:`umbmark.jsonutil`; when a
record of a robot of a kind of its own is exported, :mod:`umbmark.kinds`; for the type checker
only, :mod:`umbmark.model`)."""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import AbstractContextManager
from datetime import datetime
from pathlib import Path
from typing import Any, TypeVar

from umbmark._files import file_sha256
from umbmark.errors import InputError
from umbmark.history.address import (
    ENV_VAR,
    default_db_path,
    display_db,
    is_url,
    mask_secrets,
    resolve_db,
    resolve_db_path,
)
from umbmark.history.address import check_db_address as check_db_address
from umbmark.history.parameters import (
    AnalysisLike,
    export_parameters,
    format_export,
    parameters_from_analysis,
    runs_from_rows,
    runs_to_rows,
)
from umbmark.history.records import CLOCK_SKEW as CLOCK_SKEW
from umbmark.history.records import KINDS, DamagedRecord, HistoryError, NoHistory, Record, _short, check_robot
from umbmark.history.records import session_time_problem as session_time_problem
from umbmark.history.same_recording import SameRecording, parts_overlap, recording_part
from umbmark.history.schema import MAX_INT, MIGRATIONS, SCHEMA_VERSION, _record, make_row, retry_while_locked
from umbmark.history.schema import TABLE_COLUMNS as TABLE_COLUMNS

__all__ = [
    "ENV_VAR",
    "AnalysisLike",
    "check_robot",
    "KINDS",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "DamagedRecord",
    "HistoryError",
    "NoHistory",
    "SameRecording",
    "Record",
    "default_db_path",
    "display_db",
    "export_parameters",
    "file_sha256",
    "format_export",
    "is_url",
    "make_row",
    "mask_secrets",
    "parameters_from_analysis",
    "parts_overlap",
    "recording_part",
    "resolve_db",
    "resolve_db_path",
    "retry_while_locked",
    "runs_from_rows",
    "runs_to_rows",
]

_B = TypeVar("_B", bound="_Backend")


class _Backend:
    """What every history backend shares. A backend provides ``path`` (for messages),
    :meth:`close`, :meth:`transaction`, ``_insert(conn, row)``, ``_fetch(robot, limit,
    record_id)`` (the rows of :data:`_SELECT`, newest first) and ``_robot_counts()`` (name,
    number of records, first and last time per robot).

    Reading skips a damaged record (a value no umbmark wrote: corrupt JSON, a time that is not
    a time, text where a number belongs) and says so in :attr:`warnings`; :meth:`get` of a
    damaged record raises :class:`DamagedRecord`."""

    path: str | Path
    journal_mode: str | None

    def __enter__(self: _B) -> _B:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- what each backend provides ----------------------------------------------------------
    def close(self) -> None:
        """Close the database (release its connections)."""
        raise NotImplementedError

    def transaction(self) -> AbstractContextManager[Any]:
        """One write transaction, rolled back on any exception; yields the connection to pass to
        ``_insert``."""
        raise NotImplementedError

    def _insert(self, conn: Any, row: dict[str, Any]) -> int:
        """Store the row of :func:`make_row` inside :meth:`transaction`; returns the record's id."""
        raise NotImplementedError

    def _fetch(
        self, robot: str | None = None, limit: int | None = None, record_id: int | None = None
    ) -> Sequence[Sequence[Any]]:
        """The rows of :data:`_SELECT`, newest first (the robot's name and the id matched exactly)."""
        raise NotImplementedError

    def _same_rows(self, conn: Any, robot: str, input_sha256: str, kind: str, method: str) -> Sequence[Sequence[Any]]:
        """The rows of :data:`_SELECT` of the robot's records of one content, kind and method, on
        ``conn`` (a write transaction's connection, or None: a connection of its own)."""
        raise NotImplementedError

    def _robot_counts(self) -> Sequence[Sequence[Any]]:
        """Name, number of records, first and last time of each robot, by name."""
        raise NotImplementedError

    @property
    def warnings(self) -> list[str]:
        """The damaged records reading skipped (one message each, naming the record, the
        database and what is wrong)."""
        return list(self.__dict__.setdefault("_warnings", []))

    def _warn(self, msg: str) -> None:
        w = self.__dict__.setdefault("_warnings", [])
        if msg not in w:
            w.append(msg)

    def _decode(self, row: Sequence[Any], strict: bool = False) -> Record | None:
        """The record of one row; a damaged one is a warning and None (``strict``: raised)."""
        try:
            return _record(row, self.path)
        except DamagedRecord as e:
            if strict:
                raise
            self._warn(f"{e}: skipped")
            return None

    def add(
        self,
        robot: str,
        *,
        kind: str,
        method: str,
        results: dict[str, Any],
        parameters: dict[str, Any],
        inputs: dict[str, Any] | None = None,
        input_sha256: str | None = None,
        source: str | Path | None = None,
        parameters_in_use: dict[str, Any] | None = None,
        note: str | None = None,
        when: str | datetime | None = None,
        software_version: str | None = None,
    ) -> int:
        """Store one calibration in one transaction.

        Parameters
        ----------
        robot, kind, method, results, parameters, inputs, input_sha256, source, parameters_in_use, note, when
            As for :func:`umbmark.history.record_result`.
        software_version : str, optional
            The umbmark version that made the result (default: this one).

        Returns
        -------
        int
            The record's id.

        Raises
        ------
        InputError
            For a missing robot name, an unknown kind or a bad time.
        HistoryError
            If the database cannot be written (read-only, damaged).
        """
        row = self._row(
            robot,
            kind,
            method,
            results,
            parameters,
            inputs,
            input_sha256,
            source,
            parameters_in_use,
            note,
            when,
            software_version,
        )
        with self.transaction() as c:
            same = self._same(c, row["robot"], row["input_sha256"], row["kind"], row["method"], inputs)
            if same is not None:
                raise SameRecording(row["robot"], same, self.path)
            return self._insert(c, row)

    def same_recording(
        self, robot: str, *, kind: str, method: str, input_sha256: str | None, inputs: dict[str, Any] | None = None
    ) -> Record | None:
        """The robot's record of this recording, if it holds one: the same content hash, kind and
        method, and a part that overlaps this one (:func:`parts_overlap`: the whole recording, or
        the window of ``inputs``). :meth:`add` refuses a second one.

        Parameters
        ----------
        robot, kind, method, input_sha256, inputs
            As for :meth:`add`.

        Returns
        -------
        Record or None
            None also without a content hash (nothing to compare).
        """
        return self._same(None, check_robot(robot), input_sha256, kind, mask_secrets(str(method)), inputs)

    def _same(
        self, conn: Any, robot: str, sha: str | None, kind: str, method: str, inputs: dict[str, Any] | None
    ) -> Record | None:
        if not sha:
            return None
        part = recording_part(inputs)
        for row in self._same_rows(conn, robot, sha, kind, method):
            rec = self._decode(row)
            if rec is not None and parts_overlap(recording_part(rec.inputs), part):
                return rec
        return None

    @staticmethod
    def _row(*args: Any) -> dict[str, Any]:
        return make_row(*args)

    def records(self, robot: str | None = None, limit: int | None = None) -> list[Record]:
        """Records, oldest first; a damaged record is skipped (see :attr:`warnings`).

        Parameters
        ----------
        robot : str, optional
            Only this robot's (default: all). The name is matched literally.
        limit : int, optional
            Only the newest ``limit`` records.

        Returns
        -------
        list of Record

        Raises
        ------
        InputError
            A ``limit`` below 0 or above :data:`MAX_INT`.
        HistoryError
            If the database cannot be read.
        """
        if limit is not None and not 0 <= int(limit) <= MAX_INT:
            raise InputError(
                f"`limit` must be from 0 to {MAX_INT} (the most records the history database "
                f"{self.path} can count), got {limit}"
            )
        recs = [self._decode(r) for r in self._fetch(robot=robot, limit=limit)]
        return [r for r in reversed(recs) if r is not None]

    def get(self, record_id: int) -> Record:
        """One record by its id.

        Parameters
        ----------
        record_id : int
            The id.

        Returns
        -------
        Record

        Raises
        ------
        InputError
            If there is no such record (also for an id no database integer holds).
        DamagedRecord
            If the record is damaged.
        """
        rid = int(record_id)
        rows = self._fetch(record_id=rid) if 1 <= rid <= MAX_INT else []
        if not rows:
            raise InputError(f"no record #{record_id} in the history database {self.path}")
        rec = self._decode(rows[0], strict=True)
        assert rec is not None
        return rec

    def latest(self, robot: str, strict: bool = False) -> Record:
        """The robot's newest readable record.

        Parameters
        ----------
        robot : str
            The robot's name.
        strict : bool
            Raise when the newest record is damaged (else: the newest readable one, and a
            warning).

        Returns
        -------
        Record

        Raises
        ------
        InputError
            If the robot has no records (the message lists the robots there are).
        DamagedRecord
            ``strict`` and the newest record is damaged; or every record of the robot is.
        """
        rows = self._fetch(robot=robot, limit=1)
        if not rows:
            raise InputError(
                f"no calibrations of robot {robot!r} in the history database {self.path}" + self._known_hint(),
                data=[robot, self.path, *(str(r[0]) for r in self._robot_counts())],
            )
        rec = self._decode(rows[0], strict=strict)
        if rec is None:
            for row in self._fetch(robot=robot)[1:]:
                rec = self._decode(row)
                if rec is not None:
                    break
        if rec is None:
            _record(rows[0], self.path)  # raises: every record of the robot is damaged
            raise AssertionError  # pragma: no cover
        return rec

    def robots(self) -> list[dict[str, Any]]:
        """One summary per robot, by name.

        Returns
        -------
        list of dict
            ``robot``, ``records``, ``first_utc``, ``last_utc`` and, when it has a readable
            record, the latest one's ``latest_id``, ``emax_syst_mm``, ``Ed``, ``Eb``,
            ``wheelbase_mm``.

        Raises
        ------
        DamagedRecord
            If the database holds records and not one of them is readable.
        """
        out: list[dict[str, Any]] = []
        damaged: DamagedRecord | None = None
        for name, n, first, last in self._robot_counts():
            name = str(name)
            first, last = (t if t is None or isinstance(t, str) else _short(t) for t in (first, last))
            d: dict[str, Any] = {"robot": name, "records": n, "first_utc": first, "last_utc": last}
            if n:
                try:
                    rec = self.latest(name)
                except DamagedRecord as e:
                    self._warn(f"{e}: skipped")
                    damaged = e
                else:
                    d.update(
                        {
                            "latest_id": rec.id,
                            "emax_syst_mm": rec.emax_syst_mm,
                            "Ed": rec.ed,
                            "Eb": rec.eb,
                            "wheelbase_mm": rec.wheelbase_mm,
                        }
                    )
            out.append(d)
        if damaged is not None and not any("latest_id" in d for d in out):
            raise damaged  # records, and not one of them readable
        return out

    def _known_hint(self) -> str:
        names = [str(r[0]) for r in self._robot_counts()]
        return f" (robots: {', '.join(names)})" if names else " (it holds no robots yet)"

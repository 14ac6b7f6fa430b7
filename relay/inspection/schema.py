"""The inspection database's schema, as the migrations that build it: one SQL text for SQLite and PostgreSQL alike
(``store.py`` applies them, and says how to add one)."""

from __future__ import annotations

#: ``MIGRATIONS[i]`` takes version ``i`` to ``i + 1``. Shipped migrations are never edited (databases in the field
#: have run them): a change is a new tuple at the end.
MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (
        """CREATE TABLE missions (id TEXT PRIMARY KEY, name TEXT NOT NULL, robot TEXT NOT NULL, steps TEXT NOT NULL,
        state TEXT NOT NULL, current INTEGER NOT NULL, reason TEXT NOT NULL, created DOUBLE PRECISION NOT NULL,
        updated DOUBLE PRECISION NOT NULL, owner TEXT NOT NULL)""",
        """CREATE TABLE captures (id TEXT PRIMARY KEY, robot TEXT NOT NULL, t DOUBLE PRECISION NOT NULL,
        x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL, yaw DOUBLE PRECISION NOT NULL,
        readings TEXT NOT NULL, mission TEXT, target TEXT, image TEXT, width INTEGER NOT NULL,
        height INTEGER NOT NULL)""",
        """CREATE TABLE findings (id TEXT PRIMARY KEY, capture TEXT NOT NULL REFERENCES captures (id),
        robot TEXT NOT NULL, x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL, status TEXT NOT NULL,
        note TEXT NOT NULL, source TEXT NOT NULL, created DOUBLE PRECISION NOT NULL,
        updated DOUBLE PRECISION NOT NULL, mission TEXT, target TEXT, region TEXT)""",
        "CREATE INDEX captures_mission ON captures (mission)",
        "CREATE INDEX findings_mission ON findings (mission)",
    ),
    (  # 2: targets outlive the relay (issue #30), and the findings list pages through time
        """CREATE TABLE targets (id TEXT PRIMARY KEY, name TEXT NOT NULL, kind TEXT NOT NULL,
        x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL, facing DOUBLE PRECISION)""",
        "CREATE INDEX findings_created ON findings (created)",
        "CREATE INDEX missions_created ON missions (created)",
    ),
    (  # 3: alerts a person acknowledges (issue #30); the unacknowledged ones are loaded at start
        """CREATE TABLE alerts (id TEXT PRIMARY KEY, kind TEXT NOT NULL, robot TEXT, subject TEXT, text TEXT NOT NULL,
        severity TEXT NOT NULL, raised DOUBLE PRECISION NOT NULL, acked_by TEXT, acked_at DOUBLE PRECISION,
        ack_note TEXT NOT NULL)""",
        "CREATE INDEX alerts_raised ON alerts (raised)",
    ),
    (  # 4: every attempt to deliver an alert to a webhook, and its outcome (no secret)
        """CREATE TABLE webhook_deliveries (id TEXT PRIMARY KEY, endpoint TEXT NOT NULL, event TEXT NOT NULL,
        alert TEXT NOT NULL, attempt INTEGER NOT NULL, t DOUBLE PRECISION NOT NULL, status INTEGER,
        outcome TEXT NOT NULL, detail TEXT NOT NULL)""",
        "CREATE INDEX webhook_deliveries_t ON webhook_deliveries (t)",
    ),
    (  # 5: schedules (issue #30): missions started at times, and what became of each run
        """CREATE TABLE schedules (id TEXT PRIMARY KEY, mission TEXT NOT NULL, start DOUBLE PRECISION NOT NULL,
        repeat DOUBLE PRECISION NOT NULL, windows TEXT NOT NULL, blackouts TEXT NOT NULL,
        priority INTEGER NOT NULL, on_busy TEXT NOT NULL, created DOUBLE PRECISION NOT NULL,
        updated DOUBLE PRECISION NOT NULL, owner TEXT NOT NULL)""",
        """CREATE TABLE schedule_runs (id TEXT PRIMARY KEY, schedule TEXT NOT NULL, slot DOUBLE PRECISION NOT NULL,
        t DOUBLE PRECISION NOT NULL, outcome TEXT NOT NULL, mission TEXT, reason TEXT NOT NULL)""",
        "CREATE INDEX schedule_runs_schedule ON schedule_runs (schedule, slot)",
    ),
    (  # 6: a change finding keeps its score and the capture it was compared with (issue #30, items 3 and 5)
        "ALTER TABLE findings ADD COLUMN change DOUBLE PRECISION",
        "ALTER TABLE findings ADD COLUMN baseline TEXT",
    ),
    (  # 7: a finding keeps the trend of its reading (issue #30, item 3); a target's last rounds are read by index
        "ALTER TABLE findings ADD COLUMN trend TEXT",
        "CREATE INDEX captures_target ON captures (target, t)",
    ),
)
SCHEMA_VERSION = len(MIGRATIONS)

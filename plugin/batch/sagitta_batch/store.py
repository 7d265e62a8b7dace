"""DIR/results.sqlite: one row per (input sha256, parameters), written only by the batch client."""
import hashlib
import json
import sqlite3

# Columns added after the first release: nullable, and added by ALTER TABLE to a database that lacks them.
ADDED = (("requested_error", "REAL"),         # --target-error runs: the absolute target given to sagitta fit
         ("model_diagonal", "REAL"),          # --relative: the box diagonal the target was scaled by
         ("fit_parameters", "TEXT"),          # JSON: scheme, level, threshold... chosen by sagitta fit
         ("peer_outcome", "TEXT"),            # --peer occt: the outcome of sagitta peer occt
         ("peer_message", "TEXT"),
         ("peer_triangles", "INTEGER"),       # OCCT's triangles
         ("peer_hausdorff_lower", "REAL"),    # OCCT mesh's certified interval (upper NULL when not certified)
         ("peer_hausdorff_upper", "REAL"))

COLUMNS = ("sha256", "parameters", "path", "outcome", "message", "faces", "faces_tessellated", "triangles",
           "certified", "hausdorff_lower", "hausdorff_upper", "worst_face", "worst_face_upper", "seconds",
           "tool_version", "finished_at") + tuple(name for name, _ in ADDED)

SCHEMA = """
CREATE TABLE IF NOT EXISTS results (
  sha256 TEXT NOT NULL,            -- of the input file's bytes
  parameters TEXT NOT NULL,        -- canonical JSON (sorted keys) of the sagitta options
  path TEXT NOT NULL,              -- the path the file was read from (first path with these bytes)
  outcome TEXT NOT NULL,           -- ok | bad_input | crashed | timeout | out_of_memory
  message TEXT NOT NULL,           -- one line: the error, the signal, or '' when ok
  faces INTEGER,                   -- B-rep faces of a CAD part, patches of a patch model
  faces_tessellated INTEGER,
  triangles INTEGER,
  certified INTEGER,               -- 1 when the whole mesh has a certified Hausdorff interval
  hausdorff_lower REAL,            -- certified interval; NULL when not certified
  hausdorff_upper REAL,
  worst_face TEXT,                 -- CAD parts: the certified face with the largest upper bound
  worst_face_upper REAL,
  seconds REAL NOT NULL,           -- wall time of the child process
  tool_version TEXT NOT NULL,
  finished_at TEXT NOT NULL,       -- UTC, ISO 8601
  PRIMARY KEY (sha256, parameters)
);
"""


def file_sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def canonical(params):
    return json.dumps(params, sort_keys=True, separators=(",", ":"))


class Store:
    """The results database; every insert is its own transaction, so an interrupted batch keeps every
    row it finished and nothing half-written."""

    def __init__(self, path):
        self.db = sqlite3.connect(path)
        self.db.executescript(SCHEMA)
        have = {r[1] for r in self.db.execute("PRAGMA table_info(results)")}
        with self.db:
            for name, kind in ADDED:
                if name not in have:
                    self.db.execute(f"ALTER TABLE results ADD COLUMN {name} {kind}")

    def done_keys(self):
        return set(self.db.execute("SELECT sha256, parameters FROM results"))

    def insert(self, row):
        with self.db:  # one transaction; a duplicate key keeps the first row
            self.db.execute(f"INSERT OR IGNORE INTO results ({','.join(COLUMNS)}) VALUES "
                            f"({','.join('?' * len(COLUMNS))})", [row.get(c) for c in COLUMNS])

    def rows(self):
        cursor = self.db.execute(f"SELECT {','.join(COLUMNS)} FROM results ORDER BY path, parameters")
        return [dict(zip(COLUMNS, r)) for r in cursor]

    def close(self):
        self.db.close()

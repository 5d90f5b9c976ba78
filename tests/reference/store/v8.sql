-- A store written by E-Lab's schema version 8 (commit 9738374), as sqlite3 .dump: one finished run
PRAGMA user_version = 8;
BEGIN TRANSACTION;
CREATE TABLE chunks (
            run_id TEXT NOT NULL REFERENCES runs (id), k0 INTEGER NOT NULL,
            n INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY (run_id, k0));
INSERT INTO "chunks" VALUES('r-0000000000c8',0,2,X'000000000000E03F000000000000F03F0000000000000000000000000000E03F00000000000000409A9999999999B93F');
CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BLOB NOT NULL, created_at REAL NOT NULL);
CREATE TABLE ended_sessions (
            sid TEXT PRIMARY KEY, until REAL NOT NULL);
CREATE TABLE models (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, model TEXT NOT NULL, created_at REAL NOT NULL);
CREATE TABLE param_changes (
            run_id TEXT NOT NULL REFERENCES runs (id), k INTEGER NOT NULL,
            at REAL NOT NULL, params TEXT NOT NULL);
CREATE TABLE pins (
            name TEXT PRIMARY KEY, run_id TEXT NOT NULL REFERENCES runs (id),
            owner TEXT NOT NULL, at REAL NOT NULL);
CREATE TABLE probe (id INTEGER PRIMARY KEY CHECK (id = 1), at REAL NOT NULL);
CREATE TABLE rig_queue (
            rig TEXT NOT NULL REFERENCES rigs (rig), place INTEGER NOT NULL CHECK (place >= 1),
            user_id TEXT NOT NULL, PRIMARY KEY (rig, place), UNIQUE (rig, user_id),
            UNIQUE (rig, place, user_id));
CREATE TABLE rig_seat (
            rig TEXT PRIMARY KEY REFERENCES rigs (rig),
            place INTEGER NOT NULL DEFAULT 1 CHECK (place = 1), user_id TEXT NOT NULL,
            phase TEXT NOT NULL CHECK (phase IN ('seated', 'armed', 'running')),
            since REAL NOT NULL, until REAL NOT NULL, run_id TEXT,
            took_over INTEGER NOT NULL CHECK (took_over IN (0, 1)),
            CHECK ((phase = 'running') = (run_id IS NOT NULL)),
            FOREIGN KEY (rig, place, user_id) REFERENCES rig_queue (rig, place, user_id)
                DEFERRABLE INITIALLY DEFERRED);
CREATE TABLE rigs (
            rig TEXT PRIMARY KEY, settling INTEGER NOT NULL CHECK (settling IN (0, 1)),
            out_of_service TEXT NOT NULL, updated_at REAL NOT NULL);
CREATE TABLE runs (
            id TEXT PRIMARY KEY, plant TEXT NOT NULL, mode TEXT NOT NULL,
            experiment TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
            Ts REAL NOT NULL, channels TEXT NOT NULL, n_planned INTEGER NOT NULL,
            n_stored INTEGER NOT NULL, created_at REAL NOT NULL, started_at REAL,
            finished_at REAL, error TEXT, engine TEXT, owner TEXT, private INTEGER NOT NULL DEFAULT 0, compute TEXT);
INSERT INTO "runs" VALUES('r-0000000000c8','flexible_link','simulation','design','{"plant": "flexible_link"}','finished',0.001,'[["r", "rad"], ["u", "V"], ["theta", "rad"]]',2,2,1700000000.0,1700000000.0,1700000001.0,NULL,'sim','a-00c8',0,NULL);
CREATE TABLE tokens (
            id TEXT PRIMARY KEY, hash TEXT NOT NULL UNIQUE, owner TEXT NOT NULL,
            name TEXT NOT NULL, created_at REAL NOT NULL, last_used REAL);
CREATE INDEX runs_by_created ON runs (created_at);
CREATE INDEX runs_by_plant ON runs (plant, created_at);
CREATE INDEX param_changes_by_run ON param_changes (run_id, k);
CREATE INDEX runs_by_engine ON runs (engine, status);
CREATE INDEX runs_by_owner ON runs (owner, created_at);
CREATE INDEX runs_by_finished ON runs (finished_at);
CREATE INDEX tokens_by_owner ON tokens (owner, created_at);
CREATE INDEX controllers_by_owner ON controllers (owner, created_at);
CREATE INDEX models_by_owner ON models (owner, created_at);
COMMIT;

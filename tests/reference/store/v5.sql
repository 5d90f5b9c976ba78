-- A store written by E-Lab's schema version 5 (commit fe61848), as sqlite3 .dump
PRAGMA user_version = 5;
PRAGMA foreign_keys=OFF;
BEGIN TRANSACTION;
CREATE TABLE runs (
            id TEXT PRIMARY KEY, plant TEXT NOT NULL, mode TEXT NOT NULL,
            experiment TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
            Ts REAL NOT NULL, channels TEXT NOT NULL, n_planned INTEGER NOT NULL,
            n_stored INTEGER NOT NULL, created_at REAL NOT NULL, started_at REAL,
            finished_at REAL, error TEXT, engine TEXT, owner TEXT, private INTEGER NOT NULL DEFAULT 0, compute TEXT);
INSERT INTO runs VALUES('r-0000000000c5','belt_conveyor','simulation','design','{"controller_id": "c-0000000000c5"}','finished',0.0010000000000000000208,'[["r", "m"], ["u", "V"]]',2,2,1780000000.0,1780000000.0,1780000001.0,NULL,'sim-0','a-00c5',0,'{"steps": 2, "median_us": 11.0, "p99_us": 20.0, "max_us": 21.0, "misses": 0}');
CREATE TABLE param_changes (
            run_id TEXT NOT NULL REFERENCES runs (id), k INTEGER NOT NULL,
            at REAL NOT NULL, params TEXT NOT NULL);
CREATE TABLE chunks (
            run_id TEXT NOT NULL REFERENCES runs (id), k0 INTEGER NOT NULL,
            n INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY (run_id, k0));
INSERT INTO chunks VALUES('r-0000000000c5',0,2,X'0000000000000000000000000000f03f00000000000000400000000000000840');
CREATE TABLE probe (id INTEGER PRIMARY KEY CHECK (id = 1), at REAL NOT NULL);
CREATE TABLE tokens (
            id TEXT PRIMARY KEY, hash TEXT NOT NULL UNIQUE, owner TEXT NOT NULL,
            name TEXT NOT NULL, created_at REAL NOT NULL, last_used REAL);
CREATE TABLE pins (
            name TEXT PRIMARY KEY, run_id TEXT NOT NULL REFERENCES runs (id),
            owner TEXT NOT NULL, at REAL NOT NULL);
CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BLOB NOT NULL, created_at REAL NOT NULL);
INSERT INTO controllers VALUES('c-0000000000c5','a-00c5','belt_conveyor','mine','py','{"kind": "python", "file": "mine.py"}','{"stable": true}',X'636c617373',1780000000.0);
CREATE INDEX runs_by_created ON runs (created_at);
CREATE INDEX runs_by_plant ON runs (plant, created_at);
CREATE INDEX param_changes_by_run ON param_changes (run_id, k);
CREATE INDEX runs_by_engine ON runs (engine, status);
CREATE INDEX runs_by_owner ON runs (owner, created_at);
CREATE INDEX runs_by_finished ON runs (finished_at);
CREATE INDEX tokens_by_owner ON tokens (owner, created_at);
CREATE INDEX controllers_by_owner ON controllers (owner, created_at);
COMMIT;

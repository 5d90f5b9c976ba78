-- A store written by E-Lab's schema version 7 (commit f47c328), as sqlite3 .dump
PRAGMA user_version = 7;
BEGIN TRANSACTION;
CREATE TABLE chunks (
            run_id TEXT NOT NULL REFERENCES runs (id), k0 INTEGER NOT NULL,
            n INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY (run_id, k0));
INSERT INTO "chunks" VALUES('r-0000000000b7',0,2,X'0000000000000000000000000000F03F000000000000004000000000000008400000000000001040000000000000144000000000000018400000000000001C4000000000000020400000000000002240');
CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BLOB NOT NULL, created_at REAL NOT NULL);
CREATE TABLE ended_sessions (
            sid TEXT PRIMARY KEY, until REAL NOT NULL);
INSERT INTO "ended_sessions" VALUES('s-0000b7',4000000000.0);
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
CREATE TABLE runs (
            id TEXT PRIMARY KEY, plant TEXT NOT NULL, mode TEXT NOT NULL,
            experiment TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
            Ts REAL NOT NULL, channels TEXT NOT NULL, n_planned INTEGER NOT NULL,
            n_stored INTEGER NOT NULL, created_at REAL NOT NULL, started_at REAL,
            finished_at REAL, error TEXT, engine TEXT, owner TEXT, private INTEGER NOT NULL DEFAULT 0, compute TEXT);
INSERT INTO "runs" VALUES('r-0000000000b7','flexible_link','simulation','analysis','{"plant": "flexible_link", "signal": {"kind": "square", "amplitude": 0.5}, "K": [1.5, -2.0, 0.25, 0.001]}','finished',0.001,'[["r", "rad"], ["u", "V"], ["theta", "rad"], ["alpha", "rad"], ["x_theta", "rad"]]',10000,2,1700000000.0,NULL,NULL,NULL,'sim-0','a-00b7',0,NULL);
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

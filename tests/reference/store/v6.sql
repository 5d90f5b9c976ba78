-- A store written by E-Lab's schema version 6 (commit cb533d0), as sqlite3 .dump
PRAGMA user_version = 6;
BEGIN TRANSACTION;
CREATE TABLE chunks (
            run_id TEXT NOT NULL REFERENCES runs (id), k0 INTEGER NOT NULL,
            n INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY (run_id, k0));
CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BLOB NOT NULL, created_at REAL NOT NULL);
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
INSERT INTO "runs" VALUES('r-0000000000b6','flexible_link','simulation','analysis','{"plant": "flexible_link"}','finished',0.001,'[["r", "rad"], ["u", "V"]]',0,0,1764000000.0,1764000000.0,1764000001.0,NULL,'sim-0','anon-00000000000000b6',0,NULL);
CREATE TABLE tokens (
            id TEXT PRIMARY KEY, hash TEXT NOT NULL UNIQUE, owner TEXT NOT NULL,
            name TEXT NOT NULL, created_at REAL NOT NULL, last_used REAL);
INSERT INTO "tokens" VALUES('t-0000000000b6','abcd','instructor:prof','grader',1764000000.0,NULL);
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

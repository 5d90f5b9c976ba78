// Who may do what, as the page shows it: labels for identities and run owners, the tone
// of a run's reason, the runs list's filter in the address bar.
import type { RunsQuery } from "./api";
import type { Me, RunSummaryInfo } from "./protocol.gen";

export const ENDED = new Set(["finished", "stopped", "failed", "interrupted"]);
/** "You: guest 3f2a", or "prof · instructor". */
export function identityLabel(me: Me): string {
  if (me.role === "instructor") return `${me.account ?? me.name} · instructor`;
  return `You: ${me.name}`;
}

/** Who controls a run, as a spectator (or its owner) reads it. */
export function controlLabel(run: Pick<RunSummaryInfo, "mine" | "owner">): string {
  return run.mine ? "Your run" : `Controlled by ${run.owner}`;
}

/**
 * How a run's reason reads: a notice for what people do with runs (paused or stopped by
 * someone, paused because nobody watched), an error when the run failed or was
 * interrupted; null when there is nothing to say.
 */
export function reasonTone(state: string, reason: string | null): "notice" | "error" | null {
  if (!reason) return null;
  return state === "failed" || state === "interrupted" ? "error" : "notice";
}

export type RunsFilter = "all" | "mine" | "live";

/** The filter an address asks for (/runs?owner=me, /runs?live=true). */
export function filterFrom(query: URLSearchParams): RunsFilter {
  if (query.get("owner") === "me") return "mine";
  if (query.get("live") === "true") return "live";
  return "all";
}

/** The runs query (and address) for a filter. */
export function filterQuery(filter: RunsFilter): Pick<RunsQuery, "owner" | "live"> {
  if (filter === "mine") return { owner: "me" };
  if (filter === "live") return { live: true };
  return {};
}

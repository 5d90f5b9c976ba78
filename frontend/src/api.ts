// REST calls to /api/v1, typed by the generated wire protocol. Every failure becomes an
// ApiError carrying the server's field errors, so a form can show each next to its field.
import type {
  HelpIndex,
  HelpPage,
  AnalysisInfo,
  BodeList,
  ControllerUpload,
  DemoInfo,
  DesignOut,
  ErrorDetail,
  IdentifiedModel,
  IdentifiedModelList,
  IdentOut,
  IdentRequest,
  LoopOut,
  LoopRequest,
  LQRRequest,
  Me,
  ModelCreate,
  ModelDesignOut,
  ModelDesignRequest,
  ParamsApplied,
  ParamsUpdate,
  PlaceRequest,
  PlantDetail,
  PlantSummary,
  RigQueueInfo,
  RunCreate,
  RunInfo,
  RunList,
  RunPrediction,
  SignIn,
  StepOut,
  StepRequest,
  TokenCreated,
  TokenInfo,
  UploadedController,
  UploadedControllerList,
} from "./protocol.gen";

export type { UploadedController } from "./protocol.gen";
import { identLine } from "./wire";

export const API = "/api/v1";


export class ApiError extends Error {
  constructor(
    readonly status: number,
    readonly detail: ErrorDetail,
  ) {
    super(detail.message);
    this.name = "ApiError";
  }

  /** Field → message, for every field the server named ("controller.K.2", ...). */
  fieldMessages(): Map<string, string> {
    const out = new Map<string, string>();
    for (const e of this.detail.errors) out.set(e.field, e.message);
    if (this.detail.field && !out.has(this.detail.field)) out.set(this.detail.field, this.detail.message);
    return out;
  }
}

async function call<T>(method: string, path: string, body?: unknown): Promise<T> {
  let response: Response;
  try {
    response = await fetch(API + path, {
      method,
      headers: body === undefined ? {} : { "content-type": "application/json" },
      body: body === undefined ? undefined : JSON.stringify(body),
    });
  } catch (err) {
    throw new ApiError(0, { code: "unavailable", message: `the lab server is not reachable (${String(err)})`, field: null, errors: [] });
  }
  const text = await response.text();
  let data: unknown = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    /* not JSON: reported below */
  }
  if (!response.ok) {
    const detail = (data as { error?: ErrorDetail } | null)?.error;
    throw new ApiError(response.status, detail ?? { code: "invalid", message: `${response.status} ${response.statusText}: ${text.slice(0, 200)}`, field: null, errors: [] });
  }
  return data as T;
}

/** A recording as the JSON download gives it (runs/export.py ``iter_json``). */
export interface RecordingJson {
  Ts: number;
  k0: number;
  t: number[];
  data: Record<string, (number | null)[]>;
}

export const api = {
  plants: () => call<PlantSummary[]>("GET", "/plants"),
  help: () => call<HelpIndex>("GET", "/help"),
  helpPage: (name: string) => call<HelpPage>("GET", `/help/${encodeURIComponent(name)}`),
  plant: (id: string) => call<PlantDetail>("GET", `/plants/${encodeURIComponent(id)}`),
  analysis: (id: string) => call<AnalysisInfo>("GET", `/plants/${encodeURIComponent(id)}/analysis`),
  bode: (id: string) => call<BodeList>("GET", `/plants/${encodeURIComponent(id)}/bode`),
  step: (id: string, req: StepRequest) => call<StepOut>("POST", `/plants/${encodeURIComponent(id)}/step`, req),
  lqr: (id: string, req: LQRRequest) => call<DesignOut>("POST", `/plants/${encodeURIComponent(id)}/design/lqr`, req),
  place: (id: string, req: PlaceRequest) => call<DesignOut>("POST", `/plants/${encodeURIComponent(id)}/design/place`, req),
  runs: (query: RunsQuery = {}) => call<RunList>("GET", `/runs${queryString(query)}`),
  run: (id: string) => call<RunInfo>("GET", `/runs/${encodeURIComponent(id)}`),
  /** A run's recording as JSON (the columns asked for): the download's `t`, `data`. */
  recording: (id: string, channels: string[]) =>
    call<RecordingJson>("GET", `/runs/${encodeURIComponent(id)}/data?${new URLSearchParams({ format: "json", channels: channels.join(",") }).toString()}`),
  /** the model's prediction of a run and how far its recording is from it so far */
  prediction: (id: string) => call<RunPrediction>("GET", `/runs/${encodeURIComponent(id)}/prediction`),
  createRun: (req: RunCreate) => call<RunInfo>("POST", "/runs", req),
  stop: (id: string) => call<RunInfo>("POST", `/runs/${encodeURIComponent(id)}/stop`),
  pause: (id: string) => call<RunInfo>("POST", `/runs/${encodeURIComponent(id)}/pause`),
  resume: (id: string) => call<RunInfo>("POST", `/runs/${encodeURIComponent(id)}/resume`),
  params: (id: string, req: ParamsUpdate) => call<ParamsApplied>("POST", `/runs/${encodeURIComponent(id)}/params`, req),
  /** 409 while the run is live (stop it first), 403 unless its owner or an instructor */
  deleteRun: (id: string) => call<null>("DELETE", `/runs/${encodeURIComponent(id)}`),
  me: () => call<Me>("GET", "/me"),
  signIn: (req: SignIn) => call<Me>("POST", "/session", req),
  signOut: () => call<Me>("DELETE", "/session"),
  tokens: () => call<TokenInfo[]>("GET", "/tokens"),
  /** the answer's `token` is shown this once: the server keeps only its hash */
  createToken: (name: string) => call<TokenCreated>("POST", "/tokens", { name }),
  revokeToken: (id: string) => call<null>("DELETE", `/tokens/${encodeURIComponent(id)}`),
  /** the caller's uploaded controllers, newest first (an instructor's: everyone's) */
  controllers: (plant?: string) => call<UploadedControllerList>("GET", `/controllers${queryString({ plant })}`),
  /** 422 naming the line and column or the field when the file cannot be read; nothing is stored then */
  uploadController: (req: ControllerUpload) => call<UploadedController>("POST", "/controllers", req),
  deleteController: (id: string) => call<null>("DELETE", `/controllers/${encodeURIComponent(id)}`),
  /** keep an identified model: it gets an id and a design page to share */
  createModel: (req: ModelCreate) => call<IdentifiedModel>("POST", "/models", req),
  models: (plant?: string) => call<IdentifiedModelList>("GET", `/models${queryString({ plant })}`),
  model: (id: string) => call<IdentifiedModel>("GET", `/models/${encodeURIComponent(id)}`),
  /** 403 unless its owner or an instructor */
  deleteModel: (id: string) => call<null>("DELETE", `/models/${encodeURIComponent(id)}`),
  modelStep: (id: string, T: number) => call<StepOut>("GET", `/models/${encodeURIComponent(id)}/step?T=${T}`),
  designOnModel: (id: string, req: ModelDesignRequest) => call<ModelDesignOut>("POST", `/models/${encodeURIComponent(id)}/design`, req),
  /** a controller's loop on the plant's model: poles, verdict, root locus, margins, peak u */
  loop: (plant: string, req: LoopRequest) => call<LoopOut>("POST", `/plants/${encodeURIComponent(plant)}/loop`, req),
  /** the rig's queue as the caller sees it (422 naming `rig` on a server without one) */
  rig: () => call<RigQueueInfo>("GET", "/rig"),
  /** each answers the queue now: 409 saying why when the step is not the caller's */
  joinRig: () => call<RigQueueInfo>("POST", "/rig/queue"),
  leaveRig: () => call<RigQueueInfo>("DELETE", "/rig/queue"),
  armRig: () => call<RigQueueInfo>("POST", "/rig/arm"),
  /** 0 V at the rig's next sample (the driver or an instructor) */
  estopRig: () => call<RigQueueInfo>("POST", "/rig/estop"),
  /** instructors only (403 otherwise) */
  takeOverRig: () => call<RigQueueInfo>("POST", "/rig/takeover"),
  extendRig: (seconds: number) => call<RigQueueInfo>("POST", "/rig/extend", { seconds }),
  clearRig: () => call<RigQueueInfo>("POST", "/rig/clear"),
  demo: () => call<DemoInfo>("GET", "/demo"),
  pinDemo: (runId: string) => call<DemoInfo>("PUT", "/demo", { run_id: runId }),
  unpinDemo: () => call<null>("DELETE", "/demo"),
};

export interface RunsQuery {
  plant?: string;
  /** only the caller's runs */
  owner?: "me";
  /** only runs that are live (instructors see others' private ones too) */
  live?: boolean;
  limit?: number;
  offset?: number;
}

/** "?plant=…&live=true", or "" when nothing is asked. */
export function queryString(query: RunsQuery): string {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries<string | number | boolean | undefined>({ ...query })) if (v !== undefined && v !== false) q.set(k, String(v));
  return q.size ? "?" + q.toString() : "";
}

/**
 * Identification with progress: the server streams `{"progress": {stage, done}}` lines,
 * then `{"result": …}` or `{"error": …}` (application/x-ndjson).
 */
export async function identify(req: IdentRequest, onProgress: (stage: string, done: number) => void): Promise<IdentOut> {
  let response: Response;
  try {
    response = await fetch(API + "/ident", { method: "POST", headers: { "content-type": "application/json", accept: "application/x-ndjson" }, body: JSON.stringify(req) });
  } catch (err) {
    throw new ApiError(0, { code: "unavailable", message: `the lab server is not reachable (${String(err)})`, field: null, errors: [] });
  }
  if (!response.ok || !response.body) {
    const text = await response.text();
    let detail: ErrorDetail | undefined;
    try {
      detail = (JSON.parse(text) as { error?: ErrorDetail }).error;
    } catch {
      /* not JSON */
    }
    throw new ApiError(response.status, detail ?? { code: "invalid", message: `${response.status}: ${text.slice(0, 200)}`, field: null, errors: [] });
  }
  const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (value) buffer += value;
    let nl: number;
    while ((nl = buffer.indexOf("\n")) >= 0) {
      const line = identLine(JSON.parse(buffer.slice(0, nl)));
      buffer = buffer.slice(nl + 1);
      if (line.progress) onProgress(line.progress.stage, line.progress.done);
      if (line.result) return line.result;
      if (line.error) throw new ApiError(422, line.error);
      if (!line.progress) throw new ApiError(0, { code: "invalid", message: "an identification line without progress, result or error", field: null, errors: [] });
    }
    if (done) throw new ApiError(0, { code: "unavailable", message: "the identification stream ended without a result", field: null, errors: [] });
  }
}

/** The download address of a plant's controller template (its predefined controller). */
export function templateUrl(plant: string, format: ControllerUpload["format"]): string {
  return `${API}/plants/${encodeURIComponent(plant)}/controller-template?format=${format}`;
}

/** The download address of a run's recording. */
export function dataUrl(run: RunInfo, format: "csv" | "json" | "mat", channels?: string[]): string {
  const q = new URLSearchParams({ format });
  if (channels?.length) q.set("channels", channels.join(","));
  return `${run.data_url}?${q.toString()}`;
}

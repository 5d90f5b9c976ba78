/* Generated from shared/elab.v1.schema.json by scripts/gen-protocol.mjs (make protocol).
 * Do not edit: change the pydantic models in backend/elab/api/schemas.py instead. */

/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ClientMessage".
 */
export type ClientMessage = SetParams | Pause | Resume | Stop | ResumeFrom;
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Controller-Input".
 */
export type Controller =
  | PredefinedController
  | StateFeedbackController
  | PIDController
  | LTIControllerModel
  | OpenLoopController;
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Controller-Output".
 */
export type ControllerOut =
  | PredefinedControllerOut
  | StateFeedbackControllerOut
  | PIDControllerOut
  | LTIControllerModelOut
  | OpenLoopControllerOut;
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ServerMessage".
 */
export type ServerMessage = Hello | Frame | Status | Skipped | ParamsNotice | ErrorMessage;
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Signal-Input".
 */
export type Signal =
  StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal;
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Signal-Output".
 */
export type SignalOut =
  | StepSignalOut
  | SquareSignalOut
  | SineSignalOut
  | ChirpSignalOut
  | PRBSSignalOut
  | SamplesSignalOut;

export interface ElabProtocol {
  AnalysisInfo?: AnalysisInfo;
  ArmaxSpec?: ArmaxSpec;
  ArxSearch?: ArxSearch;
  ArxSpec?: ArxSpec;
  BodeInfo?: BodeInfo;
  BodeList?: BodeList;
  ChannelInfo?: ChannelInfo;
  "ChirpSignal-Input"?: ChirpSignal;
  "ChirpSignal-Output"?: ChirpSignalOut;
  ClientMessage?: ClientMessage;
  Complex?: Complex;
  "Controller-Input"?: Controller;
  "Controller-Output"?: ControllerOut;
  DesignOut?: DesignOut;
  ErrorBody?: ErrorBody;
  ErrorDetail?: ErrorDetail;
  ErrorMessage?: ErrorMessage;
  FieldError?: FieldError;
  FileData?: FileData;
  Frame?: Frame;
  Hello?: Hello;
  IdentOut?: IdentOut;
  IdentRequest?: IdentRequest;
  LQRRequest?: LQRRequest;
  "LTIControllerModel-Input"?: LTIControllerModel;
  "LTIControllerModel-Output"?: LTIControllerModelOut;
  N4sidSpec?: N4SidSpec;
  OeSpec?: OeSpec;
  "OpenLoopController-Input"?: OpenLoopController;
  "OpenLoopController-Output"?: OpenLoopControllerOut;
  "PIDController-Input"?: PIDController;
  "PIDController-Output"?: PIDControllerOut;
  "PRBSSignal-Input"?: PRBSSignal;
  "PRBSSignal-Output"?: PRBSSignalOut;
  ParamChangeInfo?: ParamChangeInfo;
  ParamsApplied?: ParamsApplied;
  ParamsNotice?: ParamsNotice;
  ParamsUpdate?: ParamsUpdate;
  Pause?: Pause;
  PlaceRequest?: PlaceRequest;
  PlantChannel?: PlantChannel;
  PlantDetail?: PlantDetail;
  PlantSummary?: PlantSummary;
  "PredefinedController-Input"?: PredefinedController;
  "PredefinedController-Output"?: PredefinedControllerOut;
  RankInfo?: RankInfo;
  Resume?: Resume;
  ResumeFrom?: ResumeFrom;
  RunCreate?: RunCreate;
  RunData?: RunData;
  RunInfo?: RunInfo;
  RunList?: RunList;
  RunSummaryInfo?: RunSummaryInfo;
  "SamplesSignal-Input"?: SamplesSignal;
  "SamplesSignal-Output"?: SamplesSignalOut;
  ServerMessage?: ServerMessage;
  SetParams?: SetParams;
  "Signal-Input"?: Signal;
  "Signal-Output"?: SignalOut;
  "SineSignal-Input"?: SineSignal;
  "SineSignal-Output"?: SineSignalOut;
  Skipped?: Skipped;
  "SquareSignal-Input"?: SquareSignal;
  "SquareSignal-Output"?: SquareSignalOut;
  "StateFeedbackController-Input"?: StateFeedbackController;
  "StateFeedbackController-Output"?: StateFeedbackControllerOut;
  Status?: Status;
  StepInfoOut?: StepInfoOut;
  StepOut?: StepOut;
  StepRequest?: StepRequest;
  "StepSignal-Input"?: StepSignal;
  "StepSignal-Output"?: StepSignalOut;
  Stop?: Stop;
  TransferFunctionInfo?: TransferFunctionInfo;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "AnalysisInfo".
 */
export interface AnalysisInfo {
  plant: string;
  eigenvalues: Complex[];
  verdict: "asymptotically stable" | "marginally stable" | "unstable";
  reason: string;
  controllability: RankInfo;
  observability: RankInfo;
  transfer_functions: TransferFunctionInfo[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Complex".
 */
export interface Complex {
  re: number;
  im: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RankInfo".
 */
export interface RankInfo {
  rank: number;
  n: number;
  full: boolean;
  condition_number: number | null;
  singular_values: number[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "TransferFunctionInfo".
 */
export interface TransferFunctionInfo {
  output: string;
  input: string;
  num: number[];
  den: number[];
  text: string;
  latex: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ArmaxSpec".
 */
export interface ArmaxSpec {
  kind?: "armax";
  na: number;
  nb: number;
  nc: number;
  nk?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ArxSearch".
 */
export interface ArxSearch {
  /**
   * [lowest, highest], inclusive
   *
   * @minItems 2
   * @maxItems 2
   */
  na?: [number, number];
  /**
   * [lowest, highest], inclusive
   *
   * @minItems 2
   * @maxItems 2
   */
  nb?: [number, number];
  /**
   * [lowest, highest], inclusive
   *
   * @minItems 2
   * @maxItems 2
   */
  nk?: [number, number];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ArxSpec".
 */
export interface ArxSpec {
  kind?: "arx";
  na: number;
  nb: number;
  nk?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "BodeInfo".
 */
export interface BodeInfo {
  output: string;
  /**
   * rad/s
   */
  omega: number[];
  hz: number[];
  mag_db: number[];
  phase_deg: number[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "BodeList".
 */
export interface BodeList {
  plant: string;
  input: string;
  bode: BodeInfo[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ChannelInfo".
 */
export interface ChannelInfo {
  name: string;
  unit: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ChirpSignal-Input".
 */
export interface ChirpSignal {
  kind?: "chirp";
  amplitude: number;
  f0: number;
  f1: number;
  sweep: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ChirpSignal-Output".
 */
export interface ChirpSignalOut {
  kind: "chirp";
  amplitude: number;
  f0: number;
  f1: number;
  sweep: number;
  offset: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SetParams".
 */
export interface SetParams {
  type: "set_params";
  controller?:
    | (
        | PredefinedController
        | StateFeedbackController
        | PIDController
        | LTIControllerModel
        | OpenLoopController
      )
    | null;
  signal?:
    (StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal) | null;
}
/**
 * The plant's predefined controller.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredefinedController-Input".
 */
export interface PredefinedController {
  kind?: "predefined";
}
/**
 * u = K (x_ref − x̂): one gain per state.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StateFeedbackController-Input".
 */
export interface StateFeedbackController {
  kind?: "state_feedback";
  /**
   * @minItems 1
   * @maxItems 64
   */
  K: [number, ...number[]];
  estimate?: "true_state" | "velocity_filters";
}
/**
 * C(s) = Kp + Ki/s + Kd s/(Tf s + 1), Tf = Kd/(N Kp), on e = r − y.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PIDController-Input".
 */
export interface PIDController {
  kind?: "pid";
  Kp: number;
  Ki?: number;
  Kd?: number;
  N?: number;
  /**
   * anti-windup tracking time (s)
   */
  Tt?: number | null;
}
/**
 * Any SISO LTI controller on e = r − y: num/den or A, B, C, D; dt = null: continuous.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LTIControllerModel-Input".
 */
export interface LTIControllerModel {
  kind?: "lti";
  num?: number[] | null;
  den?: number[] | null;
  A?: number[][] | null;
  B?: number[][] | null;
  C?: [] | [number[]] | null;
  D?: [] | [number[]] | null;
  dt?: number | null;
}
/**
 * No feedback: the signal is the plant input (V).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OpenLoopController-Input".
 */
export interface OpenLoopController {
  kind?: "open_loop";
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepSignal-Input".
 */
export interface StepSignal {
  kind?: "step";
  amplitude: number;
  t0?: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SquareSignal-Input".
 */
export interface SquareSignal {
  kind?: "square";
  amplitude: number;
  period: number;
  offset?: number;
  duty?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SineSignal-Input".
 */
export interface SineSignal {
  kind?: "sine";
  amplitude: number;
  /**
   * Hz
   */
  frequency: number;
  phase?: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PRBSSignal-Input".
 */
export interface PRBSSignal {
  kind?: "prbs";
  amplitude: number;
  order?: number;
  band?: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SamplesSignal-Input".
 */
export interface SamplesSignal {
  kind?: "samples";
  /**
   * @minItems 1
   * @maxItems 100000
   */
  values: [number, ...number[]];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Pause".
 */
export interface Pause {
  type: "pause";
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Resume".
 */
export interface Resume {
  type: "resume";
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Stop".
 */
export interface Stop {
  type: "stop";
}
/**
 * Send every sample from frame ``seq`` on, from the recording.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ResumeFrom".
 */
export interface ResumeFrom {
  type: "resume_from";
  seq: number;
}
/**
 * The plant's predefined controller.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredefinedController-Output".
 */
export interface PredefinedControllerOut {
  kind: "predefined";
}
/**
 * u = K (x_ref − x̂): one gain per state.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StateFeedbackController-Output".
 */
export interface StateFeedbackControllerOut {
  kind: "state_feedback";
  /**
   * @minItems 1
   * @maxItems 64
   */
  K: [number, ...number[]];
  estimate: "true_state" | "velocity_filters";
}
/**
 * C(s) = Kp + Ki/s + Kd s/(Tf s + 1), Tf = Kd/(N Kp), on e = r − y.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PIDController-Output".
 */
export interface PIDControllerOut {
  kind: "pid";
  Kp: number;
  Ki: number;
  Kd: number;
  N: number;
  /**
   * anti-windup tracking time (s)
   */
  Tt: number | null;
}
/**
 * Any SISO LTI controller on e = r − y: num/den or A, B, C, D; dt = null: continuous.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LTIControllerModel-Output".
 */
export interface LTIControllerModelOut {
  kind: "lti";
  num: number[] | null;
  den: number[] | null;
  A: number[][] | null;
  B: number[][] | null;
  C: [] | [number[]] | null;
  D: [] | [number[]] | null;
  dt: number | null;
}
/**
 * No feedback: the signal is the plant input (V).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OpenLoopController-Output".
 */
export interface OpenLoopControllerOut {
  kind: "open_loop";
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "DesignOut".
 */
export interface DesignOut {
  plant: string;
  method: "lqr" | "place";
  K: number[];
  closed_loop_poles: Complex[];
  convention: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ErrorBody".
 */
export interface ErrorBody {
  error: ErrorDetail;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ErrorDetail".
 */
export interface ErrorDetail {
  code: "invalid" | "not_found" | "conflict" | "too_many" | "too_large" | "unavailable";
  message: string;
  field: string | null;
  errors: FieldError[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "FieldError".
 */
export interface FieldError {
  field: string;
  message: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ErrorMessage".
 */
export interface ErrorMessage {
  type: "error";
  code: string;
  message: string;
  field: string | null;
}
/**
 * An uploaded table: an E-Lab CSV/JSON download, or plain numeric columns
 * (comma- or whitespace-separated; unnamed columns are c1, c2, …).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "FileData".
 */
export interface FileData {
  source?: "file";
  format?: "csv" | "json";
  name?: string;
  /**
   * the file's content
   */
  text: string;
  /**
   * @minItems 1
   * @maxItems 8
   */
  input: [string, ...string[]];
  /**
   * @minItems 1
   * @maxItems 8
   */
  output: [string, ...string[]];
  /**
   * s; default: from the file
   */
  Ts?: number | null;
}
/**
 * Samples k0 .. k0+n−1: float32 little-endian bytes per channel (t = k·Ts).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Frame".
 */
export interface Frame {
  type: "frame";
  seq: number;
  k0: number;
  n: number;
  columns: {
    [k: string]: Uint8Array;
  };
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Hello".
 */
export interface Hello {
  type: "hello";
  protocol: "elab.v1";
  run: RunInfo;
  /**
   * seq of the next live frame
   */
  live_seq: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunInfo".
 */
export interface RunInfo {
  id: string;
  plant: string;
  mode: string;
  experiment: string;
  status: "created" | "running" | "paused" | "finished" | "stopped" | "failed" | "interrupted";
  Ts: number;
  channels: ChannelInfo[];
  n_planned: number;
  n_samples: number;
  created_at: number;
  started_at: number | null;
  finished_at: number | null;
  /**
   * why it failed, stopped early or was interrupted
   */
  error: string | null;
  url: string;
  frame_samples: number;
  stream_url: string;
  data_url: string;
  request: {
    [k: string]: unknown;
  };
  param_changes: ParamChangeInfo[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamChangeInfo".
 */
export interface ParamChangeInfo {
  k: number;
  t: number;
  at: number;
  params: {
    [k: string]: unknown;
  };
}
/**
 * ``data``: the (detrended) samples, thinned to ≤ 5000 points for plotting;
 * ``analyses``: correlation, spectral, sine, arx_search, n4sid_orders (those asked for);
 * ``models``: each with fit %, polynomials or matrices, transfer functions, poles,
 * simulated and one-step outputs on the validation set and its residual analysis.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentOut".
 */
export interface IdentOut {
  data: {
    [k: string]: unknown;
  };
  analyses: {
    [k: string]: unknown;
  };
  models: {
    [k: string]: unknown;
  }[];
  notes: string[];
}
/**
 * Identification on a run's data or an uploaded table. ``split``: the estimation
 * share (the first part); the rest validates. Send ``Accept: application/x-ndjson`` to
 * receive progress lines before the result.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentRequest".
 */
export interface IdentRequest {
  data: RunData | FileData;
  detrend?: "mean" | "linear" | "none";
  split?: number;
  correlation?: boolean;
  max_lag?: number;
  spectral?: boolean;
  /**
   * Hz; default: a run's sine signal
   */
  sine_hz?: number | null;
  arx_search?: ArxSearch | null;
  n4sid_orders?: [number, number] | null;
  horizon?: number | null;
  /**
   * @maxItems 10
   */
  models?: (ArxSpec | ArmaxSpec | OeSpec | N4SidSpec)[];
}
/**
 * The recording of a run (columns by channel name, e.g. ``u`` and ``theta``).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunData".
 */
export interface RunData {
  source?: "run";
  run: string;
  /**
   * @minItems 1
   * @maxItems 8
   */
  input?: [string, ...string[]];
  /**
   * default: the plant's reference output
   */
  output?: [string, ...string[]] | null;
  /**
   * s
   */
  t_from?: number | null;
  /**
   * s
   */
  t_to?: number | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OeSpec".
 */
export interface OeSpec {
  kind?: "oe";
  nb: number;
  nf: number;
  nk?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "N4sidSpec".
 */
export interface N4SidSpec {
  kind?: "n4sid";
  /**
   * 0: chosen from the singular values
   */
  order?: number;
  /**
   * block rows; 0: the default
   */
  horizon?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LQRRequest".
 */
export interface LQRRequest {
  /**
   * diagonal or full matrix
   */
  Q: number[] | number[][];
  R?: number | number[][];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PRBSSignal-Output".
 */
export interface PRBSSignalOut {
  kind: "prbs";
  amplitude: number;
  order: number;
  band: number;
  offset: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamsApplied".
 */
export interface ParamsApplied {
  /**
   * first sample computed with the new parameters
   */
  k: number;
  t: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamsNotice".
 */
export interface ParamsNotice {
  type: "params";
  k: number;
  t: number;
  params: {
    [k: string]: unknown;
  };
}
/**
 * New controller gains and/or reference, applied from the next sample.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamsUpdate".
 */
export interface ParamsUpdate {
  controller?:
    | (
        | PredefinedController
        | StateFeedbackController
        | PIDController
        | LTIControllerModel
        | OpenLoopController
      )
    | null;
  signal?:
    (StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal) | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PlaceRequest".
 */
export interface PlaceRequest {
  /**
   * @minItems 1
   * @maxItems 64
   */
  poles: [Complex, ...Complex[]];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PlantChannel".
 */
export interface PlantChannel {
  name: string;
  unit: string;
  label: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PlantDetail".
 */
export interface PlantDetail {
  id: string;
  name: string;
  summary: string;
  modes: string[];
  experiments: string[];
  A: number[][];
  B: number[][];
  C: number[][];
  D: number[][];
  states: PlantChannel[];
  inputs: PlantChannel[];
  outputs: PlantChannel[];
  u_max: number;
  saturate: boolean;
  Ts: number;
  reference_output: string;
  operating_point: number[];
  initial_state_ranges: [unknown, unknown, unknown][];
  predefined:
    | PredefinedControllerOut
    | StateFeedbackControllerOut
    | PIDControllerOut
    | LTIControllerModelOut
    | OpenLoopControllerOut;
  predefined_design: string;
  default_signal:
    | StepSignalOut
    | SquareSignalOut
    | SineSignalOut
    | ChirpSignalOut
    | PRBSSignalOut
    | SamplesSignalOut;
  default_duration: number;
  sensors: {
    [k: string]: number[];
  };
  description: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepSignal-Output".
 */
export interface StepSignalOut {
  kind: "step";
  amplitude: number;
  t0: number;
  offset: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SquareSignal-Output".
 */
export interface SquareSignalOut {
  kind: "square";
  amplitude: number;
  period: number;
  offset: number;
  duty: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SineSignal-Output".
 */
export interface SineSignalOut {
  kind: "sine";
  amplitude: number;
  /**
   * Hz
   */
  frequency: number;
  phase: number;
  offset: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SamplesSignal-Output".
 */
export interface SamplesSignalOut {
  kind: "samples";
  /**
   * @minItems 1
   * @maxItems 100000
   */
  values: [number, ...number[]];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PlantSummary".
 */
export interface PlantSummary {
  id: string;
  name: string;
  summary: string;
  modes: string[];
  experiments: string[];
}
/**
 * A run to start. Omitted fields take the plant's defaults; units are SI.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunCreate".
 */
export interface RunCreate {
  plant: string;
  mode?: "simulation" | "rig";
  experiment?: "analysis" | "identification" | "design";
  controller?:
    | PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController;
  signal?:
    (StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal) | null;
  excitation?:
    (StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal) | null;
  excitation_at?: "reference" | "input";
  /**
   * s
   */
  duration?: number | null;
  pace?: "realtime" | "fast";
  /**
   * sensor noise seed
   */
  seed?: number | null;
  quantize?: boolean;
  saturate?: boolean | null;
  Ts?: number | null;
  x0?: number[] | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunList".
 */
export interface RunList {
  runs: RunSummaryInfo[];
  total: number;
  limit: number;
  offset: number;
}
/**
 * A run in a list: without its request and parameter changes (``GET /runs/{id}``
 * has them).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunSummaryInfo".
 */
export interface RunSummaryInfo {
  id: string;
  plant: string;
  mode: string;
  experiment: string;
  status: "created" | "running" | "paused" | "finished" | "stopped" | "failed" | "interrupted";
  Ts: number;
  channels: ChannelInfo[];
  n_planned: number;
  n_samples: number;
  created_at: number;
  started_at: number | null;
  finished_at: number | null;
  /**
   * why it failed, stopped early or was interrupted
   */
  error: string | null;
  url: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Status".
 */
export interface Status {
  type: "status";
  state: "created" | "running" | "paused" | "finished" | "stopped" | "failed" | "interrupted";
  k: number;
  error: string | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Skipped".
 */
export interface Skipped {
  type: "skipped";
  from_seq: number;
  to_seq: number;
  reason: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepInfoOut".
 */
export interface StepInfoOut {
  rise_time: number | null;
  settling_time: number | null;
  overshoot: number | null;
  peak: number | null;
  peak_time: number | null;
  steady_state: number | null;
  steady_state_error: number | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepOut".
 */
export interface StepOut {
  plant: string;
  loop: "open" | "closed";
  t: number[];
  outputs: {
    [k: string]: number[];
  };
  u: number[];
  /**
   * of the reference output (closed loop)
   */
  info: StepInfoOut | null;
  poles: Complex[];
  verdict: string;
}
/**
 * Open loop (controller omitted or open_loop) or closed loop with a controller.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepRequest".
 */
export interface StepRequest {
  controller?:
    | (
        | PredefinedController
        | StateFeedbackController
        | PIDController
        | LTIControllerModel
        | OpenLoopController
      )
    | null;
  /**
   * final time (s)
   */
  T?: number | null;
  amplitude?: number;
  n?: number;
}

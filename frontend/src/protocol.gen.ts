/* Generated from shared/elab.v1.schema.json by scripts/gen-protocol.mjs (make protocol).
 * Do not edit: change the pydantic models in backend/elab/api/schemas/ instead. */

/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ClientMessage".
 */
export type ClientMessage = SetParams | Pause | Resume | Stop | EmergencyStop | ResumeFrom;
/**
 * Why the server closes a stream (the close frame's reason says more): 4400 the
 * request was wrong (no ``elab.v1`` subprotocol, a bad ``from_seq``), 4404 no such run,
 * 4429 the identity has ``ELAB_MAX_STREAMS_PER_IDENTITY`` streams open: a client should
 * not reconnect after these. 4408: the client stopped reading while it kept sending (its
 * answers piled up); it may reconnect.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "CloseCode".
 */
export type CloseCode = 4400 | 4404 | 4408 | 4429;
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
  | PredefinedController
  | StateFeedbackControllerOut
  | PIDControllerOut
  | LTIControllerModelOut
  | OpenLoopController;
/**
 * One design on a model: ``method`` lqr, place, gain (K typed by hand) or pid.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelDesignRequest".
 */
export type ModelDesignRequest = ModelLQR | ModelPlace | ModelGain | ModelPID;
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
  StepSignalOut | SquareSignalOut | SineSignalOut | ChirpSignalOut | PRBSSignalOut | SamplesSignal;

export interface ElabProtocol {
  AnalysesOut?: AnalysesOut;
  AnalysisInfo?: AnalysisInfo;
  ArmaxSpec?: ArmaxSpec;
  ArxSearch?: ArxSearch;
  ArxSearchOut?: ArxSearchOut;
  ArxSpec?: ArxSpec;
  BodeInfo?: BodeInfo;
  BodeList?: BodeList;
  ChannelInfo?: ChannelInfo;
  "ChirpSignal-Input"?: ChirpSignal;
  "ChirpSignal-Output"?: ChirpSignalOut;
  ClientMessage?: ClientMessage;
  CloseCode?: CloseCode;
  Complex?: Complex;
  ComputeTimes?: ComputeTimes;
  ContinuousOut?: ContinuousOut;
  "Controller-Input"?: Controller;
  "Controller-Output"?: ControllerOut;
  ControllerFileRequest?: ControllerFileRequest;
  ControllerReportOut?: ControllerReportOut;
  ControllerUpload?: ControllerUpload;
  CorrelationOut?: CorrelationOut;
  DemoInfo?: DemoInfo;
  DemoPin?: DemoPin;
  DesignOut?: DesignOut;
  EmergencyStop?: EmergencyStop;
  EngineInfo?: EngineInfo;
  ErrorBody?: ErrorBody;
  ErrorDetail?: ErrorDetail;
  ErrorMessage?: ErrorMessage;
  FieldError?: FieldError;
  FileData?: FileData;
  FitOut?: FitOut;
  Frame?: Frame;
  Hello?: Hello;
  HelpEntry?: HelpEntry;
  HelpIndex?: HelpIndex;
  HelpPage?: HelpPage;
  IdentDataOut?: IdentDataOut;
  IdentDefaultsInfo?: IdentDefaultsInfo;
  IdentLine?: IdentLine;
  IdentModelOut?: IdentModelOut;
  IdentOut?: IdentOut;
  IdentProgress?: IdentProgress;
  IdentRequest?: IdentRequest;
  IdentifiedModel?: IdentifiedModel;
  IdentifiedModelList?: IdentifiedModelList;
  IndirectSpec?: IndirectSpec;
  LQRRequest?: LQRRequest;
  "LTIControllerModel-Input"?: LTIControllerModel;
  "LTIControllerModel-Output"?: LTIControllerModelOut;
  LessonStepInfo?: LessonStepInfo;
  LinkSpec?: LinkSpec;
  LoopOut?: LoopOut;
  LoopRequest?: LoopRequest;
  MarginsOut?: MarginsOut;
  Me?: Me;
  "ModelChannel-Input"?: ModelChannel;
  "ModelChannel-Output"?: ModelChannelOut;
  ModelCreate?: ModelCreate;
  ModelDesignOut?: ModelDesignOut;
  ModelDesignRequest?: ModelDesignRequest;
  ModelGain?: ModelGain;
  ModelLQR?: ModelLQR;
  ModelPID?: ModelPID;
  ModelPlace?: ModelPlace;
  N4sidOrdersOut?: N4SidOrdersOut;
  N4sidSpec?: N4SidSpec;
  OeSpec?: OeSpec;
  OpenLoopController?: OpenLoopController;
  OrderRow?: OrderRow;
  OutcomeMark?: OutcomeMark;
  "PIDController-Input"?: PIDController;
  "PIDController-Output"?: PIDControllerOut;
  "PRBSSignal-Input"?: PRBSSignal;
  "PRBSSignal-Output"?: PRBSSignalOut;
  ParamChangeInfo?: ParamChangeInfo;
  ParamDiff?: ParamDiff;
  ParamsApplied?: ParamsApplied;
  ParamsNotice?: ParamsNotice;
  ParamsUpdate?: ParamsUpdate;
  Pause?: Pause;
  PlaceRequest?: PlaceRequest;
  PlantChannel?: PlantChannel;
  PlantDetail?: PlantDetail;
  PlantSummary?: PlantSummary;
  PredefinedController?: PredefinedController;
  PredictedChannel?: PredictedChannel;
  PredictionGap?: PredictionGap;
  PredictionStep?: PredictionStep;
  RankInfo?: RankInfo;
  ResidualsOut?: ResidualsOut;
  Resume?: Resume;
  ResumeFrom?: ResumeFrom;
  RigExtend?: RigExtend;
  RigInfo?: RigInfo;
  RigPlace?: RigPlace;
  RigQueueInfo?: RigQueueInfo;
  RootLocusOut?: RootLocusOut;
  RunCreate?: RunCreate;
  RunData?: RunData;
  RunInfo?: RunInfo;
  RunList?: RunList;
  RunPrediction?: RunPrediction;
  RunSummaryInfo?: RunSummaryInfo;
  SamplesSignal?: SamplesSignal;
  ServerMessage?: ServerMessage;
  SetParams?: SetParams;
  SignIn?: SignIn;
  "Signal-Input"?: Signal;
  "Signal-Output"?: SignalOut;
  SineOut?: SineOut;
  "SineSignal-Input"?: SineSignal;
  "SineSignal-Output"?: SineSignalOut;
  Skipped?: Skipped;
  SpectralOut?: SpectralOut;
  "SquareSignal-Input"?: SquareSignal;
  "SquareSignal-Output"?: SquareSignalOut;
  "StateFeedbackController-Input"?: StateFeedbackController;
  "StateFeedbackController-Output"?: StateFeedbackControllerOut;
  StateSpaceOut?: StateSpaceOut;
  Status?: Status;
  StepCut?: StepCut;
  StepInfoOut?: StepInfoOut;
  StepOut?: StepOut;
  StepRequest?: StepRequest;
  "StepSignal-Input"?: StepSignal;
  "StepSignal-Output"?: StepSignalOut;
  Stop?: Stop;
  StreamClose?: StreamClose;
  TokenCreate?: TokenCreate;
  TokenCreated?: TokenCreated;
  TokenInfo?: TokenInfo;
  TransferFunctionInfo?: TransferFunctionInfo;
  TransferFunctionOut?: TransferFunctionOut;
  UploadedController?: UploadedController;
  UploadedControllerList?: UploadedControllerList;
  VerdictIn?: VerdictIn;
  VerdictOut?: VerdictOut;
}
/**
 * Those asked for (and possible: the first four need one input and one output).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "AnalysesOut".
 */
export interface AnalysesOut {
  correlation: CorrelationOut | null;
  spectral: SpectralOut | null;
  sine: SineOut | null;
  arx_search: ArxSearchOut | null;
  arx_search_outputs: ArxSearchOut[] | null;
  n4sid_orders: N4SidOrdersOut | null;
}
/**
 * Impulse response by correlation analysis, with its ±3σ band and the delay.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "CorrelationOut".
 */
export interface CorrelationOut {
  lags: number[];
  impulse: (number | null)[];
  band: (number | null)[];
  /**
   * samples; null: none is evident
   */
  delay: number | null;
  Ts: number;
}
/**
 * Frequency response by spectral analysis (Blackman–Tukey).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SpectralOut".
 */
export interface SpectralOut {
  /**
   * rad/s
   */
  omega: number[];
  magnitude: (number | null)[];
  phase_deg: (number | null)[];
  noise_spectrum: (number | null)[];
  window: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SineOut".
 */
export interface SineOut {
  frequency_hz: number;
  omega: number;
  magnitude: number | null;
  phase_deg: number | null;
  periods_used: number;
  samples_used: number;
}
/**
 * One row per structure: ``[na, nb, nk, validation loss]``; the best by loss, AIC, MDL.
 * With several outputs, one search per output (``output`` names it), each structure's
 * nb and nk applying to every input.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ArxSearchOut".
 */
export interface ArxSearchOut {
  output: string | null;
  rows: (number | null)[][];
  best: number[];
  aic: number[];
  mdl: number[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "N4sidOrdersOut".
 */
export interface N4SidOrdersOut {
  horizon: number;
  best: number;
  /**
   * why that order: a gap in the singular values, the best fit of the record's last third, or MDL
   */
  reason: string;
  orders: OrderRow[];
  singular_values: (number | null)[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OrderRow".
 */
export interface OrderRow {
  order: number;
  loss: number | null;
  mdl: number | null;
  aic: number | null;
  /**
   * fit % of the estimation record's last third simulated from rest by the model of its first two thirds (null: not checked)
   */
  holdout: number | null;
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
  kind: "armax";
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
  kind: "arx";
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
  kind: "chirp";
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
 * As ``POST /runs/{id}/params``: new gains and/or reference (at least one). Its
 * ``params`` notice holds the parts that changed; a change that changes nothing is not
 * applied and has no notice.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SetParams".
 */
export interface SetParams {
  controller?:
    | PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController;
  /**
   * an uploaded controller (POST /controllers) instead of `controller`
   */
  controller_id?: string;
  signal?: StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal;
  type: "set_params";
}
/**
 * The plant's predefined controller.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredefinedController".
 */
export interface PredefinedController {
  kind: "predefined";
}
/**
 * u = K (x_ref − x̂): one gain per state; or u = Nr r − K x̂ with a reference gain.
 * x̂: the true state, velocity filters, or a Luenberger observer (gain L, or placed at
 * observer_poles).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StateFeedbackController-Input".
 */
export interface StateFeedbackController {
  kind: "state_feedback";
  /**
   * @minItems 1
   * @maxItems 64
   */
  K: [number, ...number[]];
  estimate?: "true_state" | "velocity_filters" | "observer";
  /**
   * reference gain (default: the reference state's K)
   */
  Nr?: number | null;
  /**
   * observer gain: a row per state, a column per output
   */
  L?: number[][] | null;
  /**
   * where to place the observer's poles (one per state)
   */
  observer_poles?: Complex[] | null;
}
/**
 * C(s) = Kp + Ki/s + Kd s/(Tf s + 1), Tf = Kd/(N Kp), on e = r − y.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PIDController-Input".
 */
export interface PIDController {
  kind: "pid";
  Kp: number;
  Ki?: number;
  Kd?: number;
  N?: number;
  /**
   * anti-windup tracking time (s)
   */
  Tt?: number | null;
  /**
   * setpoint weight of the proportional term
   */
  b?: number;
  /**
   * setpoint weight of the derivative term
   */
  c?: number;
}
/**
 * Any SISO LTI controller on e = r − y: num/den or A, B, C, D; dt = null: continuous.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LTIControllerModel-Input".
 */
export interface LTIControllerModel {
  kind: "lti";
  num?: number[] | null;
  den?: number[] | null;
  A?: number[][] | null;
  B?: number[][] | null;
  C?: [] | [number[]] | null;
  D?: [] | [number[]] | null;
  dt?: number | null;
  /**
   * feed-forward from r to u, added: numerator
   */
  ff_num?: number[] | null;
  /**
   * and denominator
   */
  ff_den?: number[] | null;
  /**
   * with A, B, C, D: the reference's own input to the states (x' = A x + B e + B_r r; two degrees of freedom)
   */
  B_r?: number[][] | null;
  /**
   * and to u (u = C x + D e + D_r r)
   */
  D_r?: [] | [number[]] | null;
}
/**
 * No feedback: the signal is the plant input (V).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OpenLoopController".
 */
export interface OpenLoopController {
  kind: "open_loop";
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepSignal-Input".
 */
export interface StepSignal {
  kind: "step";
  amplitude: number;
  t0?: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SquareSignal-Input".
 */
export interface SquareSignal {
  kind: "square";
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
  kind: "sine";
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
  kind: "prbs";
  amplitude: number;
  order?: number;
  band?: number;
  offset?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "SamplesSignal".
 */
export interface SamplesSignal {
  kind: "samples";
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
 * The rig's emergency stop (the driver or an instructor), as ``POST /rig/estop``:
 * 0 V at the rig's next sample, whichever run this stream watches.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "EmergencyStop".
 */
export interface EmergencyStop {
  type: "estop";
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
 * A Python controller's time per step: its own compute time inside the sandbox
 * (median, p99, max) and the round trip a run waits for, in µs. A simulation waits for
 * a late answer (its samples never depend on the machine's load); the rig will hold
 * the last u.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ComputeTimes".
 */
export interface ComputeTimes {
  steps: number;
  median_us: number;
  p99_us: number;
  max_us: number;
  round_trip_median_us: number;
  round_trip_p99_us: number;
  /**
   * steps answered after the deadline
   */
  misses: number;
  /**
   * steps whose own compute time passed the deadline
   */
  slow: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ContinuousOut".
 */
export interface ContinuousOut {
  A: number[][];
  B: number[][];
  C: number[][];
  D: number[][];
}
/**
 * u = K (x_ref − x̂): one gain per state; or u = Nr r − K x̂ with a reference gain.
 * x̂: the true state, velocity filters, or a Luenberger observer (gain L, or placed at
 * observer_poles).
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
  estimate: "true_state" | "velocity_filters" | "observer";
  /**
   * reference gain (default: the reference state's K)
   */
  Nr: number | null;
  /**
   * observer gain: a row per state, a column per output
   */
  L: number[][] | null;
  /**
   * where to place the observer's poles (one per state)
   */
  observer_poles: Complex[] | null;
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
  /**
   * setpoint weight of the proportional term
   */
  b: number;
  /**
   * setpoint weight of the derivative term
   */
  c: number;
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
  /**
   * feed-forward from r to u, added: numerator
   */
  ff_num: number[] | null;
  /**
   * and denominator
   */
  ff_den: number[] | null;
  /**
   * with A, B, C, D: the reference's own input to the states (x' = A x + B e + B_r r; two degrees of freedom)
   */
  B_r: number[][] | null;
  /**
   * and to u (u = C x + D e + D_r r)
   */
  D_r: [] | [number[]] | null;
}
/**
 * A controller as a file to download (what an upload reads back).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ControllerFileRequest".
 */
export interface ControllerFileRequest {
  controller:
    | PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController;
  format?: "toml" | "json" | "mat" | "npz" | "py";
  name?: string | null;
}
/**
 * The report on the plant's linear model, or for a Python controller on trial runs in
 * its sandbox (docs/controllers.md).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ControllerReportOut".
 */
export interface ControllerReportOut {
  stable: boolean;
  /**
   * z: a discrete controller, poles in z; trial: a Python controller, checked by trial runs on the model (no poles or margins)
   */
  domain: "s" | "z" | "trial";
  poles: Complex[];
  gain_margin_db: number | null;
  phase_margin_deg: number | null;
  /**
   * V, for a step of the default reference
   */
  peak_u: number | null;
  u_max: number;
  step_amplitude: number;
  rig_ready: boolean;
  problems: string[];
  warnings: string[];
  /**
   * a Python controller's, in its trial
   */
  compute: ComputeTimes | null;
  /**
   * what the trial ran (a Python controller)
   */
  trial: string | null;
}
/**
 * A controller file (docs/controllers.md): TOML, JSON or Python as text, .mat or .npz as
 * base64.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ControllerUpload".
 */
export interface ControllerUpload {
  plant: string;
  format: "toml" | "json" | "mat" | "npz" | "py";
  /**
   * the file: text, or base64 for mat/npz
   */
  content: string;
  /**
   * default: the `name` in the file, else '<plant> <format> controller'
   */
  name?: string | null;
}
/**
 * The class demo an instructor pinned (``run`` null: none).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "DemoInfo".
 */
export interface DemoInfo {
  run: RunSummaryInfo | null;
  pinned_by: string | null;
  pinned_at: number | null;
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
   * why it failed, stopped early (who stopped it) or was interrupted; while it is paused, who paused it or why
   */
  error: string | null;
  /**
   * a Python controller's time per step over the run, once it ended
   */
  compute: ComputeTimes | null;
  /**
   * how it went beyond its status, once it ended ([]: nothing to say; null: not known, a live run or one recorded before outcomes were kept)
   */
  outcome: OutcomeMark[] | null;
  url: string;
  /**
   * who started it, as others see them (guest 3f2a, a name)
   */
  owner: string;
  private: boolean;
  /**
   * the caller started it
   */
  mine: boolean;
  /**
   * the caller may pause, resume, stop, change and delete it (its owner or an instructor)
   */
  can_control: boolean;
}
/**
 * Something about how a run went that its state alone would hide, from the sample
 * ``k`` (at ``t`` s) on: ``left_range`` (an output left its model's valid range),
 * ``saturated`` (the input sat at the actuator's limit), ``beyond_actuator`` (saturation
 * off and |u| above the actuator's limit), ``ran_away`` (a closed loop's output ended far
 * from the reference); ``text`` says it with the numbers.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OutcomeMark".
 */
export interface OutcomeMark {
  kind: "left_range" | "saturated" | "beyond_actuator" | "ran_away";
  k: number;
  t: number;
  text: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "DemoPin".
 */
export interface DemoPin {
  run_id: string;
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
 * The engine that steps runs, as the web process sees it.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "EngineInfo".
 */
export interface EngineInfo {
  id: string;
  /**
   * started and answering
   */
  up: boolean;
  /**
   * why it is not up, or what is wrong while up
   */
  problem: string | null;
  /**
   * restarts after its process was lost
   */
  restarts: number;
  pid: number | null;
  /**
   * since it last reported (s)
   */
  heartbeat_age_s: number | null;
  /**
   * its live runs, as it last said
   */
  live_runs: number | null;
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
  code:
    | "invalid"
    | "not_found"
    | "conflict"
    | "too_many"
    | "too_large"
    | "unavailable"
    | "forbidden"
    | "unauthorized"
    | "unsupported_media_type"
    | "timeout";
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
  source: "file";
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
  /**
   * for two_stage: the columns of the signals that drove the loop
   */
  reference?: [string, ...string[]] | null;
}
/**
 * Fit % per output: on the validation set simulated from a zero initial state (the
 * published figures' convention), from the best initial state, and one step ahead; on the
 * estimation set simulated from the best initial state. The headline is the validation
 * simulation fit that means something for the model: from the estimated initial state
 * when a mode does not decay within the validation record (integrating, unstable or
 * slower than the record), else from zero.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "FitOut".
 */
export interface FitOut {
  validation_simulation: (number | null)[];
  validation_simulation_x0: (number | null)[];
  validation_one_step: (number | null)[];
  estimation_simulation: (number | null)[];
  headline: (number | null)[];
  headline_x0: "zero" | "estimated";
  headline_why: string;
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
   * why it failed, stopped early (who stopped it) or was interrupted; while it is paused, who paused it or why
   */
  error: string | null;
  /**
   * a Python controller's time per step over the run, once it ended
   */
  compute: ComputeTimes | null;
  /**
   * how it went beyond its status, once it ended ([]: nothing to say; null: not known, a live run or one recorded before outcomes were kept)
   */
  outcome: OutcomeMark[] | null;
  url: string;
  /**
   * who started it, as others see them (guest 3f2a, a name)
   */
  owner: string;
  private: boolean;
  /**
   * the caller started it
   */
  mine: boolean;
  /**
   * the caller may pause, resume, stop, change and delete it (its owner or an instructor)
   */
  can_control: boolean;
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
 * A documentation page the app offers: its ``name`` (``GET /help/{name}``) and what
 * it is for.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "HelpEntry".
 */
export interface HelpEntry {
  name: string;
  summary: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "HelpIndex".
 */
export interface HelpIndex {
  pages: HelpEntry[];
}
/**
 * A documentation page: its title (its first heading) and its markdown (links to
 * other pages as ``name.md``).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "HelpPage".
 */
export interface HelpPage {
  name: string;
  title: string;
  markdown: string;
}
/**
 * The data as analysed (detrended), thinned to ≤ 5000 points per series: every
 * ``step``-th sample; the first ``estimation`` samples estimate, the rest validate:
 * the rest of the data (``validation`` "split"), or a separate record (``validation``
 * "record"), whose samples follow the estimation record's on the time axis.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentDataOut".
 */
export interface IdentDataOut {
  N: number;
  Ts: number;
  estimation: number;
  validation: "split" | "record";
  step: number;
  trend: string;
  t: number[];
  /**
   * [input][sample]
   */
  u: number[][];
  /**
   * [output][sample]
   */
  y: number[][];
  input_names: string[];
  output_names: string[];
  input_units: string[];
  output_units: string[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentDefaultsInfo".
 */
export interface IdentDefaultsInfo {
  /**
   * the CLI's syntax: arx:4,4,1; n4sid:4
   */
  models: string;
  decimate: number;
  why: string;
}
/**
 * One line of the NDJSON answer: progress while it works, then the result or an error.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentLine".
 */
export interface IdentLine {
  progress: IdentProgress | null;
  result: IdentOut | null;
  error: ErrorDetail | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentProgress".
 */
export interface IdentProgress {
  stage: string;
  done: number;
}
/**
 * Every result of an identification (docs/identification.md).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentOut".
 */
export interface IdentOut {
  data: IdentDataOut;
  analyses: AnalysesOut;
  models: IdentModelOut[];
  notes: string[];
  /**
   * on the data (and the ARX order search)
   */
  verdicts: VerdictOut[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentModelOut".
 */
export interface IdentModelOut {
  name: string;
  kind: "arx" | "armax" | "oe" | "n4sid" | "link";
  orders: {
    [k: string]: number;
  };
  /**
   * the model's own parameters (polynomials with their standard deviations, loss, FPE, AIC; for ARMAX and OE the winning start and every start's loss (`start`, `start_losses`), for ARMAX whether C's roots sit at the 0.99 margin; for n4sid the singular values, x0, how B and D were had ('subspace' or 'simulation'), whether A was stabilised and which poles were reflected ([|z| before, after] each) with the estimation fits as estimated and reflected, and how K was had: 'riccati' or 'none' (an output-error predictor)
   */
  parameters: {
    [k: string]:
      | (number | null)[]
      | (number | null)[][]
      | boolean
      | number
      | null
      | string
      | {
          [k: string]: number | null;
        };
  };
  fit: FitOut;
  noise_variance: (number | null)[][];
  /**
   * [re, im] in the z plane
   */
  poles: number[][];
  stable: boolean;
  ss: StateSpaceOut;
  /**
   * [output][input]
   */
  tf: TransferFunctionOut[][];
  /**
   * by the inverse zero-order hold; null where no real one exists
   */
  continuous: ContinuousOut | null;
  /**
   * [output][sample] on the validation set, from a zero initial state; null where the simulation overflowed (a model that diverges)
   */
  simulated: (number | null)[][];
  /**
   * the same from the estimated state
   */
  simulated_x0: (number | null)[][];
  one_step: (number | null)[][];
  residuals: ResidualsOut | null;
  verdicts: VerdictOut[];
  /**
   * its worst verdict's: 'poor' is not to be designed on as it is
   */
  level: "good" | "caution" | "poor";
}
/**
 * The innovations form x⁺ = A x + B u + K e, y = C x + D u + e (discrete, Ts).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StateSpaceOut".
 */
export interface StateSpaceOut {
  A: number[][];
  B: number[][];
  C: number[][];
  D: number[][];
  K: number[][];
  Ts: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "TransferFunctionOut".
 */
export interface TransferFunctionOut {
  /**
   * powers of z, highest first
   */
  num: number[];
  den: number[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ResidualsOut".
 */
export interface ResidualsOut {
  lags: number[];
  autocorrelation: (number | null)[];
  cross_lags: number[];
  cross_correlation: (number | null)[];
  bound: number | null;
  white: boolean;
  independent: boolean;
}
/**
 * A verdict in plain words (docs/identification.md, "Verdicts").
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "VerdictOut".
 */
export interface VerdictOut {
  /**
   * on the data: feedback, excitation, noise, quantisation, delay, length, order_search, two_stage; on a model: stability, integrator, fit, residuals, order, physics
   */
  topic: string;
  level: "good" | "caution" | "poor";
  finding: string;
  /**
   * what to change; null when nothing needs to
   */
  advice: string | null;
}
/**
 * Identification on a run's data or an uploaded table. ``split``: the estimation
 * share (the first part); the rest validates. Or ``validation``: a separate record to
 * validate on, given as ``data`` is, with the same channels and sample time; ``data``
 * then all estimates and ``split`` is not used. Both records together are within the
 * body's limit (``ELAB_MAX_UPLOAD``) and 2,000,000 samples. Send ``Accept:
 * application/x-ndjson`` to receive progress lines before the result.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentRequest".
 */
export interface IdentRequest {
  data: RunData | FileData;
  /**
   * a separate validation record (the same channels and sample time); with detrend 'mean', the estimation record's means are removed from both
   */
  validation?: (RunData | FileData) | null;
  /**
   * 'mean' and 'linear' take each part's own trend off; 'none' keeps the data as recorded; 'operating_point' takes the run's plant's rest off every channel (a run's data only: a file's rest is not known), which keeps an integrating plant's record as it is and takes off offsets like the upright pendulum's π
   */
  detrend?: "mean" | "linear" | "none" | "operating_point";
  /**
   * not used with a validation record
   */
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
   * keep every n-th sample after an anti-aliasing filter (1: all); the analysis runs at n·Ts
   */
  decimate?: number;
  /**
   * @maxItems 10
   */
  models?: (ArxSpec | ArmaxSpec | OeSpec | N4SidSpec | LinkSpec)[];
  /**
   * closed loop: the two-stage method with a first stage of this many taps (the estimation part's input replaced by its FIR prediction from data.reference; validation reads the measured input); null: the direct method
   */
  two_stage?: number | null;
  /**
   * closed loop: the indirect method with this known controller (one input, one output, every sample): the models are fitted to the loop from w = u + C y to y and turned into the plant with C; null: the direct method
   */
  indirect?: IndirectSpec | null;
}
/**
 * The recording of a run (columns by channel name, e.g. ``u`` and ``theta``).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunData".
 */
export interface RunData {
  source: "run";
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
  /**
   * for two_stage: the signals that drove the loop, recorded channels or 'excitation' (the run's input excitation as it was requested); default: r and, if the run had one at the input, the excitation
   */
  reference?: [string, ...string[]] | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "OeSpec".
 */
export interface OeSpec {
  kind: "oe";
  nb: number;
  nf: number;
  nk?: number;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "N4sidSpec".
 */
export interface N4SidSpec {
  kind: "n4sid";
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
 * The rotary flexible link's physics (input u; outputs θ then α, in rad; detrend
 * none): docs/identification.md.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LinkSpec".
 */
export interface LinkSpec {
  kind: "link";
}
/**
 * The loop's known controller for the indirect method, at the data's sample time:
 * u = w − C(q) y with C(q) = num(q⁻¹) / den(q⁻¹); ``u = r − 0.6 y`` is ``num [0.6]``,
 * ``den [1]``.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IndirectSpec".
 */
export interface IndirectSpec {
  /**
   * @minItems 1
   * @maxItems 50
   */
  num: [number, ...number[]];
  /**
   * @minItems 1
   * @maxItems 50
   */
  den: [number, ...number[]];
}
/**
 * A kept model: anyone with its id may read it and design on it; its owner or an
 * instructor may delete it.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentifiedModel".
 */
export interface IdentifiedModel {
  id: string;
  plant: string;
  name: string;
  /**
   * who kept it, as others see them
   */
  owner: string;
  mine: boolean;
  can_delete: boolean;
  created_at: number;
  Ts: number;
  A: number[][];
  B: number[][];
  C: number[][];
  D: number[][];
  input: ModelChannelOut;
  outputs: ModelChannelOut[];
  source: string;
  kind: string;
  fit: (number | null)[];
  verdicts: VerdictOut[];
  /**
   * z
   */
  poles: Complex[];
  /**
   * continuous equivalents ln(z)/Ts (null: a pole at z ≤ 0 has none)
   */
  poles_s: Complex[] | null;
  stable: boolean;
  /**
   * per output, powers of z
   */
  tf: TransferFunctionOut[];
  /**
   * why a design on it cannot run on the plant (null: it can)
   */
  not_runnable: string | null;
  url: string;
  /**
   * the design page for it (a shareable link)
   */
  page: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelChannel-Output".
 */
export interface ModelChannelOut {
  name: string;
  /**
   * SI: rad, m, V, …
   */
  unit: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "IdentifiedModelList".
 */
export interface IdentifiedModelList {
  models: IdentifiedModel[];
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LQRRequest".
 */
export interface LQRRequest {
  /**
   * diagonal or full matrix
   */
  Q: [number, ...number[]] | [[number, ...number[]], ...[number, ...number[]][]];
  R?: number | [number[], ...number[][]];
}
/**
 * One run of the plant's lesson, ready to start: the fields of ``POST /runs`` it
 * sets (with ``plant`` and ``experiment`` "analysis").
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LessonStepInfo".
 */
export interface LessonStepInfo {
  title: string;
  text: string;
  controller:
    | PredefinedController
    | StateFeedbackControllerOut
    | PIDControllerOut
    | LTIControllerModelOut
    | OpenLoopController;
  signal:
    | StepSignalOut
    | SquareSignalOut
    | SineSignalOut
    | ChirpSignalOut
    | PRBSSignalOut
    | SamplesSignal;
  duration: number;
  /**
   * the absolute initial state (null: the operating point)
   */
  x0: number[] | null;
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
 * What the design page shows of a loop besides its step: poles, verdict, margins, root
 * locus, and the peak |u| a reference step of ``amplitude`` asks (null: unstable).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LoopOut".
 */
export interface LoopOut {
  plant: string;
  closed_loop_poles: Complex[];
  verdict: "asymptotically stable" | "marginally stable" | "unstable";
  reason: string;
  margins: MarginsOut;
  root_locus: RootLocusOut;
  amplitude: number;
  peak_u: number | null;
  u_max: number;
  /**
   * the peak passes the actuator limit
   */
  saturates: boolean;
}
/**
 * Of the loop broken at the plant input (null: no crossover).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "MarginsOut".
 */
export interface MarginsOut {
  gain_margin_db: number | null;
  phase_margin_deg: number | null;
  /**
   * rad/s
   */
  gain_crossover: number | null;
  /**
   * rad/s
   */
  phase_crossover: number | null;
}
/**
 * Closed-loop poles as the loop gain k is scaled (k = 1: as designed): branch i at
 * ``gains[j]`` is (re[i][j], im[i][j]) in s or z.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RootLocusOut".
 */
export interface RootLocusOut {
  domain: "s" | "z";
  gains: number[];
  re: (number | null)[][];
  im: (number | null)[][];
  /**
   * the open loop's (k = 0)
   */
  poles: Complex[];
  zeros: Complex[];
}
/**
 * A controller for a plant's loop (LoopOut).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "LoopRequest".
 */
export interface LoopRequest {
  controller:
    | PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController;
  /**
   * reference step; default: the plant's default amplitude
   */
  amplitude?: number | null;
}
/**
 * Who the server takes the caller for.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "Me".
 */
export interface Me {
  /**
   * what owned objects record (null: no identity)
   */
  id: string | null;
  /**
   * as others see it
   */
  name: string;
  role: "student" | "instructor";
  /**
   * cookie: the browser's anonymous identity; session: an instructor signed in; token: an API token
   */
  via: "cookie" | "session" | "token" | "none";
  /**
   * the instructor account's name (null: none)
   */
  account: string | null;
  /**
   * this server has instructor accounts to sign in to
   */
  sign_in: boolean;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelChannel-Input".
 */
export interface ModelChannel {
  name: string;
  /**
   * SI: rad, m, V, …
   */
  unit?: string;
}
/**
 * A discrete model to keep, as identification gives it (``POST /ident``: a model's
 * ``ss`` and the data's names): x⁺ = A x + B u, y = C x + D u at sample time Ts, one
 * input, at most 20 states and 8 outputs.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelCreate".
 */
export interface ModelCreate {
  /**
   * the plant it models
   */
  plant: string;
  name: string;
  /**
   * s
   */
  Ts: number;
  /**
   * @minItems 1
   * @maxItems 20
   */
  A: [[number, ...number[]], ...[number, ...number[]][]];
  /**
   * n × 1
   *
   * @minItems 1
   * @maxItems 20
   */
  B: [[number, ...number[]], ...[number, ...number[]][]];
  /**
   * one row per output, n columns
   *
   * @minItems 1
   * @maxItems 20
   */
  C: [[number, ...number[]], ...[number, ...number[]][]];
  /**
   * one row per output, one column
   *
   * @minItems 1
   * @maxItems 20
   */
  D: [[number, ...number[]], ...[number, ...number[]][]];
  input?: ModelChannel1;
  /**
   * @minItems 1
   * @maxItems 8
   */
  outputs: [ModelChannel, ...ModelChannel[]];
  /**
   * where it came from: a run, a file
   */
  source?: string;
  /**
   * arx, armax, oe, n4sid, …
   */
  kind?: string;
  /**
   * validation fit per output (%), as identification said
   *
   * @maxItems 8
   */
  fit?: (number | null)[];
  /**
   * identification's verdicts on it, shown beside its fit
   *
   * @maxItems 20
   */
  verdicts?: VerdictIn[];
}
export interface ModelChannel1 {
  name: string;
  /**
   * SI: rad, m, V, …
   */
  unit?: string;
}
/**
 * A verdict of identification's (:class:`VerdictOut`) as a model to keep carries it.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "VerdictIn".
 */
export interface VerdictIn {
  topic: string;
  level: "good" | "caution" | "poor";
  finding: string;
  advice?: string | null;
}
/**
 * A design on a kept model. ``controller`` is what ``POST /runs`` takes (with ``Ts`` =
 * ``run_Ts``) and ``POST /plants/{plant_id}/controller-file`` writes; null when the
 * model's outputs are not the plant's (``not_runnable`` says why).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelDesignOut".
 */
export interface ModelDesignOut {
  plant: string;
  closed_loop_poles: Complex[];
  verdict: "asymptotically stable" | "marginally stable" | "unstable";
  reason: string;
  margins: MarginsOut;
  root_locus: RootLocusOut;
  amplitude: number;
  peak_u: number | null;
  u_max: number;
  /**
   * the peak passes the actuator limit
   */
  saturates: boolean;
  model: string;
  method: "lqr" | "place" | "gain" | "pid";
  domain: "discrete" | "continuous";
  K: number[] | null;
  /**
   * reference gain: u = Nr r − K x̂
   */
  Nr: number | null;
  /**
   * observer gain, states × outputs
   */
  L: number[][] | null;
  observer_poles: Complex[] | null;
  step: StepOut;
  controller:
    | (
        | PredefinedController
        | StateFeedbackControllerOut
        | PIDControllerOut
        | LTIControllerModelOut
        | OpenLoopController
      )
    | null;
  /**
   * the sample time a run needs (null: the plant's)
   */
  run_Ts: number | null;
  not_runnable: string | null;
  /**
   * LQR by an output weight: the q used (after robust lowering)
   */
  output_weight: number | null;
  /**
   * how q was chosen, when the robust rule lowered it or could not
   */
  weight_note: string | null;
  /**
   * the same controller on the lab's physics model, as a run of it goes (noise-free sensors, the plant's actuator limit), its outputs absolute: what the identified model's step is checked against (null: it cannot run on the plant)
   */
  on_plant: StepOut | null;
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
  /**
   * the response is cut where an output left the plant's range
   */
  cut: StepCut | null;
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
 * Where a response left the plant's range (the linear model's validity): it ends
 * with the first sample outside.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StepCut".
 */
export interface StepCut {
  output: string;
  /**
   * s, the first sample outside
   */
  t: number;
  /**
   * the range, absolute, in the output's SI unit
   */
  low: number;
  high: number;
}
/**
 * LQR: Q (diagonal or full) or an output weight q (Q = q Cᵣᵀ Cᵣ; neither: Bryson's
 * rule q = (0.8 u_max / amplitude)², 80 % of the actuator's limit for the step), and R.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelLQR".
 */
export interface ModelLQR {
  /**
   * discrete: on the model as identified; continuous: its ZOH inverse
   */
  domain?: "discrete" | "continuous";
  /**
   * height of the reference step for the response and the peak u (the output's SI unit; default: the plant's default reference amplitude)
   */
  amplitude?: number | null;
  /**
   * horizon of the step (s)
   */
  T?: number | null;
  /**
   * one per state (s or z); default: the loop's, three times faster
   */
  observer_poles?: Complex[] | null;
  method: "lqr";
  Q?: [number, ...number[]] | [[number, ...number[]], ...[number, ...number[]][]] | null;
  output_weight?: number | null;
  R?: number;
  /**
   * with an output weight (given or Bryson's): lower it by factors of √2 until the loop on the model has at least 6 dB of gain and 30° of phase margin, so that a model's small errors (an identified resonance) do not undo the design
   */
  robust?: boolean;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelPlace".
 */
export interface ModelPlace {
  /**
   * discrete: on the model as identified; continuous: its ZOH inverse
   */
  domain?: "discrete" | "continuous";
  /**
   * height of the reference step for the response and the peak u (the output's SI unit; default: the plant's default reference amplitude)
   */
  amplitude?: number | null;
  /**
   * horizon of the step (s)
   */
  T?: number | null;
  /**
   * one per state (s or z); default: the loop's, three times faster
   */
  observer_poles?: Complex[] | null;
  method: "place";
  /**
   * @minItems 1
   * @maxItems 20
   */
  poles: [Complex, ...Complex[]];
}
/**
 * A gain typed by hand: one per model state.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelGain".
 */
export interface ModelGain {
  /**
   * discrete: on the model as identified; continuous: its ZOH inverse
   */
  domain?: "discrete" | "continuous";
  /**
   * height of the reference step for the response and the peak u (the output's SI unit; default: the plant's default reference amplitude)
   */
  amplitude?: number | null;
  /**
   * horizon of the step (s)
   */
  T?: number | null;
  /**
   * one per state (s or z); default: the loop's, three times faster
   */
  observer_poles?: Complex[] | null;
  method: "gain";
  /**
   * @minItems 1
   * @maxItems 20
   */
  K: [number, ...number[]];
}
/**
 * A PID on the error of the reference output (derivative filter N).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ModelPID".
 */
export interface ModelPID {
  /**
   * discrete: on the model as identified; continuous: its ZOH inverse
   */
  domain?: "discrete" | "continuous";
  /**
   * height of the reference step for the response and the peak u (the output's SI unit; default: the plant's default reference amplitude)
   */
  amplitude?: number | null;
  /**
   * horizon of the step (s)
   */
  T?: number | null;
  method: "pid";
  Kp: number;
  Ki?: number;
  Kd?: number;
  N?: number;
}
/**
 * One value a change altered: ``field`` as in the request (``signal.amplitude``,
 * ``controller.K.1``), values in SI units (``null``: not set).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamDiff".
 */
export interface ParamDiff {
  field: string;
  before: number | string | boolean | null;
  after: number | string | boolean | null;
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
  /**
   * what the change altered, field by field; empty when the values given are those the run uses (nothing is then applied or recorded, and k is the sample the run has reached)
   */
  changed: ParamDiff[];
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
 * New controller gains and/or reference, applied from the next sample (at least one;
 * an omitted one, or one equal to what the run uses, stays as it is).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "ParamsUpdate".
 */
export interface ParamsUpdate {
  controller?:
    | PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController;
  /**
   * an uploaded controller (POST /controllers) instead of `controller`
   */
  controller_id?: string;
  signal?: StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal;
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
    | PredefinedController
    | StateFeedbackControllerOut
    | PIDControllerOut
    | LTIControllerModelOut
    | OpenLoopController;
  predefined_design: string;
  default_signal:
    | StepSignalOut
    | SquareSignalOut
    | SineSignalOut
    | ChirpSignalOut
    | PRBSSignalOut
    | SamplesSignal;
  default_duration: number;
  /**
   * the absolute initial state the analysis experiment starts from (null: the operating point)
   */
  default_x0: number[] | null;
  sensors: {
    [k: string]: number[];
  };
  /**
   * a pole at s = 0: an output integrates the input (identification keeps its runs' data as recorded by default: removing the input's mean would add a ramp the plant never made)
   */
  integrating: boolean;
  identification: IdentDefaultsInfo1;
  /**
   * the runs a presenter steps through with one key (the chapter's: the plant alone, an arbitrary gain, the designed controller)
   */
  lesson: LessonStepInfo[];
  description: string;
}
/**
 * what the identification page proposes for this plant's runs, and why
 */
export interface IdentDefaultsInfo1 {
  /**
   * the CLI's syntax: arx:4,4,1; n4sid:4
   */
  models: string;
  decimate: number;
  why: string;
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
 * One predicted column: ``values[k]`` is sample ``k`` (SI units, as the recording).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredictedChannel".
 */
export interface PredictedChannel {
  name: string;
  unit: string;
  label: string;
  values: number[];
}
/**
 * How far the recording is from the prediction on one channel, over the samples
 * compared: root mean square and largest ``|run − prediction|`` (the channel's unit), and
 * when the largest happened (s).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredictionGap".
 */
export interface PredictionGap {
  name: string;
  unit: string;
  rms: number;
  max_abs: number;
  t_max: number;
}
/**
 * One step of the recorded reference (constant from ``t`` for ``span`` s; the first
 * 20 steps) and the reference output's response to it in the run and in the
 * prediction, with the design page's characteristics (``StepInfoOut``: times in s from
 * the step, overshoot in % of the change), each measured from where its own output was
 * at the step (the run's: ``start``) toward ``target`` (absolute, the output's
 * ``unit``). Null: fewer than two samples measured.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "PredictionStep".
 */
export interface PredictionStep {
  output: string;
  unit: string;
  t: number;
  span: number;
  start: number;
  target: number;
  run: StepInfoOut | null;
  prediction: StepInfoOut | null;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RigExtend".
 */
export interface RigExtend {
  /**
   * s added to the driver's slot
   */
  seconds: number;
}
/**
 * The flexible-link rig of this server, if it has one (``ELAB_RIG``).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RigInfo".
 */
export interface RigInfo {
  engine: EngineInfo;
  /**
   * the rig answers the host loop
   */
  connected: boolean;
  rig_id: string | null;
  firmware: string | null;
  /**
   * an elab rig-emulator process, not hardware
   */
  emulated: boolean;
  /**
   * why it is not connected, or out of service
   */
  problem: string | null;
  /**
   * after a run: 0 V until still, then re-zero
   */
  settling: boolean;
  /**
   * samples the host loop answered since it started
   */
  samples: number;
  /**
   * of them, answered more than 1 ms after arriving
   */
  late_1ms: number;
  /**
   * response latency, last 10 s (µs)
   */
  latency_p50_us: number | null;
  latency_p99_us: number | null;
  latency_max_us: number | null;
}
/**
 * Where the caller stands in the rig's queue.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RigPlace".
 */
export interface RigPlace {
  /**
   * 1: the head (the driver once seated); null: not queued
   */
  place: number | null;
  /**
   * estimated s until the caller is seated (0: driving; null: not queued, or the rig is out of service)
   */
  wait_s: number | null;
  /**
   * the caller holds the rig's seat
   */
  driving: boolean;
  /**
   * unix s by which the caller, seated, must arm the rig or lose the turn
   */
  arm_by: number | null;
}
/**
 * The rig's queue now (``GET /rig``; every queue operation answers with it).
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RigQueueInfo".
 */
export interface RigQueueInfo {
  rig: RigInfo;
  /**
   * someone may drive it (out of service: nobody)
   */
  in_service: boolean;
  /**
   * why nobody may drive it
   */
  out_of_service: string | null;
  /**
   * a run ended: 0 V until the link is still, then it re-zeroes; the next run starts after
   */
  settling: boolean;
  /**
   * who holds the seat (a display name)
   */
  driver: string | null;
  /**
   * seated: must arm within the grace; armed: may start a run; running
   */
  phase: ("seated" | "armed" | "running") | null;
  /**
   * the run on the rig now
   */
  run_id: string | null;
  /**
   * unix s the driver's slot ends
   */
  slot_ends_at: number | null;
  /**
   * an instructor took the rig over
   */
  taken_over: boolean;
  /**
   * users in the queue behind the driver
   */
  waiting: number;
  /**
   * a driver's turn (ELAB_RIG_SLOT)
   */
  slot_s: number;
  /**
   * how long a seated driver may take to arm (ELAB_RIG_GRACE)
   */
  grace_s: number;
  you: RigPlace;
  /**
   * the server's unix s these times are relative to
   */
  now: number;
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
   * the plant's sensor noise (white, GET /plants/{id} sensors.noise_std). Default: on for identification runs and whenever a seed is given, else off
   */
  noise?: boolean | null;
  /**
   * sensor noise seed (default with noise on: a random one; the recorded request holds it, so the run can be repeated)
   */
  seed?: number | null;
  /**
   * round the outputs to the sensors' resolution (sensors.quantum). Default: on for identification runs, else off
   */
  quantize?: boolean | null;
  saturate?: boolean | null;
  Ts?: number | null;
  x0?: number[] | null;
  /**
   * only its owner and instructors may see it (default: anyone with its link)
   */
  private?: boolean;
  /**
   * an uploaded controller (POST /controllers) to run; its law replaces `controller`, and the recorded request holds both
   */
  controller_id?: string | null;
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
 * What the model predicts for a run (the same plant model, law, reference, excitation,
 * start state and actuator limit with ideal sensors, its live changes replayed) and how
 * far the recording is from it. ``n``: samples predicted (the run's, or the first
 * ``ELAB_PREDICTION_SAMPLES``); ``compared``: recorded samples compared so far (a live
 * run's grow); ``diverged_at``: s where the predicted loop diverged or the predicted
 * controller failed (the prediction ends there); ``steps``: each step of the reference
 * over the samples compared, the run's response beside the prediction's.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "RunPrediction".
 */
export interface RunPrediction {
  run_id: string;
  model: string;
  Ts: number;
  n: number;
  compared: number;
  replayed: number;
  diverged_at: number | null;
  channels: PredictedChannel[];
  gaps: PredictionGap[];
  steps: PredictionStep[];
  notes: string[];
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
 * via the `definition` "SignIn".
 */
export interface SignIn {
  name: string;
  password: string;
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
/**
 * How the server ends a stream it refuses: the websocket close frame's code and reason.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "StreamClose".
 */
export interface StreamClose {
  code: CloseCode;
  reason: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "TokenCreate".
 */
export interface TokenCreate {
  /**
   * what it is for
   */
  name: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "TokenCreated".
 */
export interface TokenCreated {
  id: string;
  name: string;
  created_at: number;
  last_used: number | null;
  /**
   * send as Authorization: Bearer <token>; shown once, never again
   */
  token: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "TokenInfo".
 */
export interface TokenInfo {
  id: string;
  name: string;
  created_at: number;
  last_used: number | null;
}
/**
 * A controller a user uploaded, with the law read from it and its report.
 *
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "UploadedController".
 */
export interface UploadedController {
  id: string;
  plant: string;
  name: string;
  format: string;
  owner: string;
  mine: boolean;
  created_at: number;
  /**
   * the law read from the file (none for a Python controller: its code is it)
   */
  controller:
    | (
        | PredefinedController
        | StateFeedbackControllerOut
        | PIDControllerOut
        | LTIControllerModelOut
        | OpenLoopController
      )
    | null;
  /**
   * a Python controller's source (not in the list: GET it by id)
   */
  code: string | null;
  report: ControllerReportOut;
  url: string;
}
/**
 * This interface was referenced by `ElabProtocol`'s JSON-Schema
 * via the `definition` "UploadedControllerList".
 */
export interface UploadedControllerList {
  controllers: UploadedController[];
}

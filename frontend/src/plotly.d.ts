// plotly.js-basic-dist-min is plotly.js's prebuilt partial bundle with the scatter, bar and
// pie traces (the app draws scatter traces only): the same API and types as plotly.js.
declare module "plotly.js-basic-dist-min" {
  export * from "plotly.js";
}

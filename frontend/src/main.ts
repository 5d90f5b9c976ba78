// E-Lab in the browser: the routes, the shell (header, classroom mode) and the views.
// The home page is in this bundle; every other view loads with its first visit, so the
// home page does not wait for plotly.js and KaTeX (5 MB) — issue 15.
import "./style.css";
import { identityLabel } from "./access";
import { fill, h, link } from "./dom";
import { identity } from "./identity";
import { Router, type View } from "./router";
import { plantDetail } from "./views/common";
import { home } from "./views/home";

const CLASSROOM = "elab.classroom";

function shell(): HTMLElement {
  const toggle = h("button.link", { type: "button", "aria-pressed": "false", title: "Large fonts for a projector" }, "Classroom mode");
  const set = (on: boolean) => {
    document.body.classList.toggle("classroom", on);
    toggle.setAttribute("aria-pressed", String(on));
    localStorage.setItem(CLASSROOM, on ? "1" : "0");
    window.dispatchEvent(new Event("resize")); // plots redraw with the new font size
  };
  toggle.addEventListener("click", () => set(!document.body.classList.contains("classroom")));
  set(localStorage.getItem(CLASSROOM) === "1");
  const main = h("main#main", { tabindex: "-1" });
  document.body.append(
    h("a.skip", { href: "#main" }, "Skip to content"),
    h("div.topbar", link("/", h("span.logo", "E-Lab")), h("nav", link("/", "Experiments"), link("/runs", "Runs"), link("/help", "Help"), h("a", { href: "/api/v1/docs" }, "API")), whoAmI(), toggle),
    main,
  );
  return main;
}

/** Who the lab takes this browser for, linking to the account page. */
function whoAmI(): HTMLElement {
  const who = h("a.who", { href: "/account", "data-link": true, "data-testid": "who", title: "Your identity, instructor sign-in and API tokens" }, "Account");
  identity.listen((me) => {
    fill(who, identityLabel(me));
    who.dataset.role = me.role;
  });
  void identity.get().catch(() => undefined); // unreachable server: the pages say so
  return who;
}

const main = shell();
const router = new Router(main, (root) => {
  document.title = "Page not found · E-Lab";
  root.append(h("header.page", h("h1", "Page not found"), h("p", `Nothing lives at ${location.pathname}. `, link("/", "Go to the start page"), ".")));
});
// debugging and benchmark knobs, for the console and tests/bench/liveplot.py: the plot's
// settings once a view that plots has loaded
const knobs: { plotSettings?: object } = {};
(window as unknown as { elab: object }).elab = knobs;

/** A view loaded on first use; ``plots``: it draws plots, so the plot's knobs appear. A
 * plant's pages ask for the plant while their module loads, not after. */
function lazy(load: () => Promise<View>, plots = false): View {
  return async (root, params, query) => {
    if (params.id && location.pathname.startsWith("/plants/")) void plantDetail(params.id);
    const view = await load();
    if (plots && !knobs.plotSettings) knobs.plotSettings = (await import("./plot")).plotSettings;
    return view(root, params, query);
  };
}

router
  .add("/", home)
  .add("/plants/:id", lazy(async () => (await import("./views/plant")).plantPage))
  .add("/plants/:id/analysis", lazy(async () => (await import("./views/analysis")).analysisPage, true))
  .add("/plants/:id/identification", lazy(async () => (await import("./views/identification")).identificationPage, true))
  .add("/plants/:id/design", lazy(async () => (await import("./views/design")).designPage, true))
  .add("/runs", lazy(async () => (await import("./views/runs")).runsPage))
  .add("/runs/:id", lazy(async () => (await import("./views/run")).runPage, true))
  .add("/account", lazy(async () => (await import("./views/account")).accountPage))
  .add("/compare", lazy(async () => (await import("./views/compare")).comparePage, true))
  .add("/help", lazy(async () => (await import("./views/help")).helpPage))
  .add("/help/:name", lazy(async () => (await import("./views/help")).helpPage));
void router.render();

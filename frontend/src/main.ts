// E-Lab in the browser: the routes, the shell (header, classroom mode) and the views.
import "katex/dist/katex.min.css";
import "./style.css";
import { identityLabel } from "./access";
import { fill, h, link } from "./dom";
import { identity } from "./identity";
import { plotSettings } from "./plot";
import { Router } from "./router";
import { accountPage } from "./views/account";
import { analysisPage } from "./views/analysis";
import { designPage } from "./views/design";
import { home } from "./views/home";
import { identificationPage } from "./views/identification";
import { plantPage } from "./views/plant";
import { runPage } from "./views/run";
import { runsPage } from "./views/runs";

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
    h("div.topbar", link("/", h("span.logo", "E-Lab")), h("nav", link("/", "Experiments"), link("/runs", "Runs"), h("a", { href: "/api/v1/docs" }, "API")), whoAmI(), toggle),
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
router
  .add("/", home)
  .add("/plants/:id", plantPage)
  .add("/plants/:id/analysis", analysisPage)
  .add("/plants/:id/identification", identificationPage)
  .add("/plants/:id/design", designPage)
  .add("/runs", runsPage)
  .add("/runs/:id", runPage)
  .add("/account", accountPage);
void router.render();

// debugging and benchmark knobs, for the console and tests/bench/liveplot.py
(window as unknown as { elab: object }).elab = { plotSettings };

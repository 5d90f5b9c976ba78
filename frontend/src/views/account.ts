// Who you are to the lab: this browser's anonymous identity, instructor sign-in, and API
// tokens that let scripts act as you.
import { identityLabel } from "../access";
import { api } from "../api";
import { copyText, fill, h, link } from "../dom";
import { identity } from "../identity";
import type { Me, TokenCreated, TokenInfo } from "../protocol.gen";
import { errorText, failure, loading, pageHeader } from "./common";

export async function accountPage(root: HTMLElement): Promise<() => void> {
  const view = new AccountView();
  root.append(pageHeader("Account", [], h("p.lead", "Who the lab takes you for, instructor sign-in, and API tokens for scripts.")), view.root);
  await view.load();
  return () => view.destroy();
}

const VIA: Record<Me["via"], string> = {
  cookie: "this browser's anonymous identity (a cookie the lab gave it)",
  session: "signed in as an instructor",
  token: "an API token",
  none: "no identity: you may watch runs, not start them",
};

class AccountView {
  readonly root: HTMLElement;
  private readonly who = h("section.panel", { "aria-labelledby": "who-h" }, loading());
  private readonly signIn = h("section.panel", { "aria-labelledby": "sign-h" });
  private readonly tokens = h("section.panel", { "aria-labelledby": "tokens-h" });
  private readonly tokenList = h("div", { "data-testid": "token-list" });
  private readonly created = h("div.token-box", { hidden: true, "data-testid": "new-token", "aria-live": "polite" });
  private unlisten: () => void = () => undefined;

  constructor() {
    this.root = h("div.account", h("div.two", this.who, this.signIn), this.tokens, explanation());
  }

  async load(): Promise<void> {
    let me: Me;
    try {
      me = await identity.get();
    } catch (err) {
      fill(this.who, failure(err));
      return;
    }
    await this.show(me);
    this.unlisten = identity.listen((changed) => void this.show(changed));
  }

  private async show(me: Me): Promise<void> {
    fill(
      this.who,
      h("h2#who-h", "Who you are"),
      h("p.identity", { "data-testid": "identity" }, h("strong", identityLabel(me)), h("br"), h("span.muted", VIA[me.via])),
      me.id ? h("p.muted", "Identity ", h("code", me.id)) : null,
    );
    this.signInPanel(me);
    this.tokensPanel(me);
    await this.listTokens();
  }

  private signInPanel(me: Me): void {
    if (me.via === "session") {
      const msg = h("p.error", { role: "alert" });
      const out = h("button", { type: "button", onclick: () => void this.signOut(msg) }, "Sign out");
      fill(this.signIn, h("h2#sign-h", "Instructor"), h("p", `Signed in as ${me.name}. You may pause, stop and delete any run, see private runs and pin the class demo.`), h("div.actions", out), msg);
      return;
    }
    if (!me.sign_in) {
      fill(this.signIn, h("h2#sign-h", "Instructor sign-in"), h("p.muted", "This lab has no instructor accounts. Its operator makes them (", link("/help/access", "Help: who may do what"), "); students need none."));
      return;
    }
    const name = h("input#sign-name", { name: "name", autocomplete: "username", required: true });
    const password = h("input#sign-password", { name: "password", type: "password", autocomplete: "current-password", required: true });
    const msg = h("p.error", { role: "alert", "data-testid": "sign-in-error" });
    const submit = h("button.primary", { type: "submit" }, "Sign in");
    const form = h(
      "form",
      {
        novalidate: true,
        "aria-label": "instructor sign-in",
        onsubmit: (ev: Event) => {
          ev.preventDefault();
          void this.signInWith(name.value.trim(), password, submit, msg);
        },
      },
      h("div.field", h("label", { for: "sign-name" }, "Name"), name),
      h("div.field", h("label", { for: "sign-password" }, "Password"), password),
      h("div.actions", submit),
      msg,
    );
    fill(this.signIn, h("h2#sign-h", "Instructor sign-in"), h("p.muted", "For instructors with an account on this lab (its operator makes them). Students need no account."), form);
  }

  private async signInWith(name: string, password: HTMLInputElement, submit: HTMLButtonElement, msg: HTMLElement): Promise<void> {
    fill(msg);
    if (!name || !password.value) return void fill(msg, "Enter your instructor name and password.");
    submit.disabled = true;
    try {
      identity.set(await api.signIn({ name, password: password.value }));
    } catch (err) {
      password.value = "";
      fill(msg, errorText(err));
    } finally {
      submit.disabled = false;
    }
  }

  private async signOut(msg: HTMLElement): Promise<void> {
    try {
      identity.set(await api.signOut());
    } catch (err) {
      fill(msg, errorText(err));
    }
  }

  private tokensPanel(me: Me): void {
    this.created.hidden = true;
    fill(this.created);
    if (!me.id) {
      fill(this.tokens, h("h2#tokens-h", "API tokens"), h("p.muted", "Tokens belong to an identity: this connection has none."));
      return;
    }
    const name = h("input#token-name", { name: "name", maxlength: "100", placeholder: "e.g. grading script" });
    const msg = h("p.error", { role: "alert", "data-testid": "token-error" });
    const form = h(
      "form.inline-form",
      {
        novalidate: true,
        "aria-label": "new API token",
        onsubmit: (ev: Event) => {
          ev.preventDefault();
          void this.create(name, msg);
        },
      },
      h("div.field", h("label", { for: "token-name" }, "What it is for"), name),
      h("button.primary", { type: "submit" }, "Create token"),
    );
    const as = me.role === "instructor" ? "as you, with an instructor's rights: keep it as safe as your password" : `as ${me.name}, this browser's identity`;
    fill(this.tokens, h("h2#tokens-h", "API tokens"), h("p", `A token lets a script or an autograder use the API ${as}. Revoke one you no longer need.`), form, msg, this.created, this.tokenList);
  }

  private async create(name: HTMLInputElement, msg: HTMLElement): Promise<void> {
    fill(msg);
    if (!name.value.trim()) return void fill(msg, "Say what the token is for (a name to recognise it by).");
    try {
      this.showCreated(await api.createToken(name.value.trim()));
      name.value = "";
      await this.listTokens();
    } catch (err) {
      fill(msg, errorText(err));
    }
  }

  private showCreated(t: TokenCreated): void {
    const value = h("input.mono", { readonly: true, value: t.token, "aria-label": "the new token", "data-testid": "token-value", onfocus: (ev: Event) => (ev.target as HTMLInputElement).select() });
    const copy = h("button", { type: "button", onclick: () => void copyText(t.token, copy) }, "Copy");
    this.created.hidden = false;
    fill(
      this.created,
      h("p", h("strong", `Your new token “${t.name}”`)),
      h("div.copy-row", value, copy),
      h("p.notice", "Copy it now: it is shown only this once and never again. If you lose it, revoke it and create another."),
      h("p", "A script sends it with every request, in the header ", h("code", "Authorization: Bearer <token>"), ", for example:"),
      h("pre.request", `curl -H "Authorization: Bearer ${t.token}" ${location.origin}/api/v1/me`),
    );
  }

  private async listTokens(): Promise<void> {
    try {
      const tokens = await api.tokens();
      fill(this.tokenList, tokens.length ? this.tokenTable(tokens) : h("p.muted", "No tokens yet."));
    } catch (err) {
      fill(this.tokenList, h("p.error", errorText(err)));
    }
  }

  private tokenTable(tokens: TokenInfo[]): HTMLElement {
    const when = (t: number | null) => (t === null ? "never" : new Date(t * 1000).toLocaleString());
    return h(
      "table.tokens",
      h("thead", h("tr", h("th", "Name"), h("th", "Created"), h("th", "Last used"), h("th", ""))),
      h(
        "tbody",
        ...tokens.map((t) =>
          h("tr", { "data-token": t.id }, h("td", t.name), h("td", when(t.created_at)), h("td", when(t.last_used)), h("td", h("button", { type: "button", onclick: () => void this.revoke(t) }, "Revoke"))),
        ),
      ),
    );
  }

  private async revoke(t: TokenInfo): Promise<void> {
    if (!confirm(`Revoke the token “${t.name}”? Scripts that use it stop working.`)) return;
    try {
      await api.revokeToken(t.id);
    } catch (err) {
      fill(this.tokenList, h("p.error", errorText(err)));
      return;
    }
    await this.listTokens();
  }

  destroy(): void {
    this.unlisten();
  }
}

function explanation(): HTMLElement {
  return h(
    "section.panel",
    { "aria-labelledby": "how-h" },
    h("h2#how-h", "How the lab knows who you are"),
    h(
      "ul",
      h("li", h("strong", "Anonymous, one identity per browser. "), "The first time this browser opened the lab it was given an identity of its own (a cookie; no account, no name). Runs you start belong to it; others see them as “guest” and four characters. Another browser or a private window is another guest; clearing this site's cookies starts a new one, which cannot control the old one's runs."),
      h("li", h("strong", "Instructors sign in "), "with a name and password the lab's operator set up. They may pause, stop and delete any run, see private runs and pin a run as the class demo on the start page."),
      h("li", h("strong", "API tokens "), "let scripts and autograders act as the identity that made them, sending the token in the Authorization header."),
      h("li", "Anyone with a run's link may watch it and download its data, unless it was started as a private run. Only its owner and instructors may pause, resume, stop, change or delete it."),
    ),
  );
}

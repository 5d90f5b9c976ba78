// Who this browser is to the server (GET /me): asked once per page load, asked again
// after a sign-in or sign-out, and told to whoever listens (the header, open views).
// The anonymous identity's cookie is HttpOnly: the page can only learn it from /me.
import { api } from "./api";
import type { Me } from "./protocol.gen";

export type MeListener = (me: Me) => void;

export class IdentityStore {
  private current: Promise<Me> | null = null;
  private readonly listeners = new Set<MeListener>();

  constructor(private readonly fetchMe: () => Promise<Me> = api.me) {}

  /** Who I am (one request however many ask; a failed one is asked again next time). */
  get(): Promise<Me> {
    if (!this.current) {
      const p = this.fetchMe();
      this.current = p;
      const mine = () => this.current === p; // not overtaken by set() or refresh()
      void p.then(
        (me) => mine() && this.tell(me),
        () => {
          if (mine()) this.current = null;
        },
      );
    }
    return this.current;
  }

  /** Ask the server again (another tab may have signed in or out). */
  refresh(): Promise<Me> {
    this.current = null;
    return this.get();
  }

  /** The server's answer to a sign-in or sign-out: the new identity. */
  set(me: Me): void {
    this.current = Promise.resolve(me);
    this.tell(me);
  }

  /** Called with every identity learnt from now on; returns the unsubscribe. */
  listen(fn: MeListener): () => void {
    this.listeners.add(fn);
    return () => this.listeners.delete(fn);
  }

  private tell(me: Me): void {
    for (const fn of this.listeners) fn(me);
  }
}

/** The page's identity. */
export const identity = new IdentityStore();

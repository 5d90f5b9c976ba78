import { describe, expect, it } from "vitest";
import { controlLabel, filterFrom, filterQuery, identityLabel, reasonTone, type RunsFilter } from "./access";
import { queryString } from "./api";

describe("identityLabel", () => {
  it("names a guest as others see it, an instructor by account and role", () => {
    expect(identityLabel({ id: "a-3f2a9c", name: "guest 3f2a", role: "student", via: "cookie", account: null, sign_in: true })).toBe("You: guest 3f2a");
    expect(identityLabel({ id: "i-prof", name: "prof (instructor)", role: "instructor", via: "session", account: "prof", sign_in: true })).toBe("prof · instructor");
    expect(identityLabel({ id: "i-x", name: "x (instructor)", role: "instructor", via: "token", account: "x", sign_in: true })).toBe("x · instructor");
  });
});

describe("controlLabel", () => {
  it("says whose run it is", () => {
    expect(controlLabel({ mine: true, owner: "guest 3f2a" })).toBe("Your run");
    expect(controlLabel({ mine: false, owner: "guest 3f2a" })).toBe("Controlled by guest 3f2a");
  });
});

describe("reasonTone", () => {
  it("makes what people do with runs a notice and failures errors", () => {
    expect(reasonTone("paused", "paused by prof (instructor)")).toBe("notice");
    expect(reasonTone("paused", "paused: its owner has had no connection to it for 60 s")).toBe("notice");
    expect(reasonTone("stopped", "stopped by its owner")).toBe("notice");
    expect(reasonTone("failed", "the controller diverged")).toBe("error");
    expect(reasonTone("interrupted", "the engine process ended")).toBe("error");
    expect(reasonTone("running", null)).toBeNull();
    expect(reasonTone("finished", "")).toBeNull();
  });
});

describe("the runs filter", () => {
  it("round-trips through the address", () => {
    for (const f of ["all", "mine", "live"] as RunsFilter[]) {
      expect(filterFrom(new URLSearchParams(queryString(filterQuery(f))))).toBe(f);
    }
  });
  it("asks the API for owner=me or live=true", () => {
    expect(queryString({ ...filterQuery("mine"), limit: 25 })).toBe("?owner=me&limit=25");
    expect(queryString({ plant: "belt_conveyor", ...filterQuery("live") })).toBe("?plant=belt_conveyor&live=true");
    expect(queryString({ ...filterQuery("all"), offset: undefined })).toBe("");
  });
  it("takes anything else for all runs", () => {
    expect(filterFrom(new URLSearchParams("owner=someone&live=maybe"))).toBe("all");
  });
});

import { describe, expect, it } from "vitest";
import { base64, FileRefused, formatOf, kib, MAX_FILE_BYTES, uploadOf } from "./controllerfile";

const bytes = (...xs: number[]) => Uint8Array.from(xs);
const file = (name: string, data: Uint8Array | string) => new File([typeof data === "string" ? data : data.slice()], name);

describe("formatOf", () => {
  it("takes the format from the extension, in any case", () => {
    expect(formatOf("ctrl.toml")).toBe("toml");
    expect(formatOf("My Controller.JSON")).toBe("json");
    expect(formatOf("lqr.v7.mat")).toBe("mat");
    expect(formatOf("ctrl.npz")).toBe("npz");
    expect(formatOf("softer.py")).toBe("py");
    expect(formatOf("PI.controller.PY")).toBe("py");
  });

  it.each(["ctrl", "ctrl.txt", "toml", "ctrl.toml.bak", "ctrl.npy", ".mat.zip", "ctrl.pyc", "ctrl.ipynb", "ctrl.py.txt", "py"])("refuses %s", (name) => {
    expect(formatOf(name)).toBeNull();
  });
});

describe("base64", () => {
  it("encodes the RFC 4648 test vectors", () => {
    const enc = (s: string) => base64(new TextEncoder().encode(s));
    expect([enc(""), enc("f"), enc("fo"), enc("foo"), enc("foob"), enc("fooba"), enc("foobar")]).toEqual(["", "Zg==", "Zm8=", "Zm9v", "Zm9vYg==", "Zm9vYmE=", "Zm9vYmFy"]);
  });

  it("encodes every byte value, from an ArrayBuffer or a view into one", () => {
    const all = Uint8Array.from({ length: 256 }, (_, i) => i);
    expect(base64(all.buffer)).toBe(base64(all));
    expect(base64(bytes(0, 255, 128))).toBe("AP+A");
    expect(base64(all.subarray(254))).toBe("/v8=");
  });

  it("round-trips a file larger than its chunk (64 KiB of every byte value)", () => {
    const big = Uint8Array.from({ length: MAX_FILE_BYTES }, (_, i) => (i * 7919) % 256);
    const back = Uint8Array.from(atob(base64(big.buffer)), (ch) => ch.charCodeAt(0));
    expect(back).toEqual(big);
  });
});

describe("kib", () => {
  it("says sizes in KiB", () => {
    expect(kib(65536)).toBe("64 KiB");
    expect(kib(65537)).toBe("64.1 KiB");
    expect(kib(70000)).toBe("68.4 KiB");
  });
});

describe("uploadOf", () => {
  it("sends TOML and JSON as text, named by the file's own name field", async () => {
    expect(await uploadOf(file("c.toml", 'K = [20, -93.5]  # θ, α\n'), "flexible_link")).toEqual({ plant: "flexible_link", format: "toml", content: "K = [20, -93.5]  # θ, α\n" });
    expect(await uploadOf(file("c.json", '{"kind": "open_loop"}'), "belt_conveyor")).toEqual({ plant: "belt_conveyor", format: "json", content: '{"kind": "open_loop"}' });
  });

  it("sends Python as text, named by the file name", async () => {
    const source = "import numpy as np\n\nclass Controller:\n    def step(self, t, y, r):\n        return 18.0 * (r - y[0])  # θ\n";
    expect(await uploadOf(file("softer.py", source), "flexible_link")).toEqual({ plant: "flexible_link", format: "py", content: source, name: "softer.py" });
    expect((await uploadOf(file(`${"p".repeat(90)}.py`, source), "p")).name).toHaveLength(80);
  });

  it("sends .mat and .npz as base64, named by the file name", async () => {
    expect(await uploadOf(file("pid.mat", bytes(0, 1, 2, 250)), "belt_conveyor")).toEqual({ plant: "belt_conveyor", format: "mat", content: "AAEC+g==", name: "pid.mat" });
    const long = `${"x".repeat(100)}.npz`;
    expect((await uploadOf(file(long, bytes(80, 75)), "p")).name).toHaveLength(80);
  });

  it.each([
    ["notes.txt", "x", /notes\.txt: not a controller file; allowed: \.toml, \.json, \.mat, \.npz or \.py/],
    ["big.py", "#".repeat(MAX_FILE_BYTES + 1), /big\.py is 64\.1 KiB: .* at most 64 KiB\. Nothing was sent\./],
    ["empty.py", "", /empty\.py is empty/],
    ["latin1.py", bytes(0x23, 0x20, 0xb5, 0x73), /latin1\.py is not UTF-8 text/],
    ["big.mat", new Uint8Array(MAX_FILE_BYTES + 1), /big\.mat is 64\.1 KiB: a controller file may be at most 64 KiB\. Nothing was sent\./],
    ["big.toml", "#".repeat(70_000), /big\.toml is 68\.4 KiB: .* at most 64 KiB/],
    ["empty.toml", "", /empty\.toml is empty/],
    ["latin1.toml", bytes(0x4b, 0x20, 0x3d, 0xe9), /latin1\.toml is not UTF-8 text/],
  ])("refuses %s in the page", async (name, data, message) => {
    const got = uploadOf(file(name, data), "flexible_link");
    await expect(got).rejects.toBeInstanceOf(FileRefused);
    await expect(got).rejects.toThrow(message);
  });

  it("takes exactly 64 KiB", async () => {
    const req = await uploadOf(file("max.npz", new Uint8Array(MAX_FILE_BYTES)), "p");
    expect(req.content.length).toBe(Math.ceil(MAX_FILE_BYTES / 3) * 4);
  });
});

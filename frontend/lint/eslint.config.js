// ESLint for the app's TypeScript (make lint): typescript-eslint's type-checked rules on
// ../src, with the app's tsconfig. The house rules that matter fail the build here:
// no `any`, no unchecked casts of `any`, every switch on a union exhaustive, no floating
// promises.
import js from "@eslint/js";
import tseslint from "typescript-eslint";
import { dirname } from "node:path";
import { fileURLToPath } from "node:url";

const app = dirname(dirname(fileURLToPath(import.meta.url)));

export default tseslint.config(
  { ignores: ["**/protocol.gen.ts", "**/wire.validate.gen.*"] },
  js.configs.recommended,
  ...tseslint.configs.recommendedTypeChecked,
  {
    files: ["**/*.ts"],
    languageOptions: {
      parserOptions: { project: "./tsconfig.json", tsconfigRootDir: app },
    },
    rules: {
      "@typescript-eslint/switch-exhaustiveness-check": "error",
      "@typescript-eslint/no-explicit-any": "error",
      "@typescript-eslint/no-floating-promises": "error",
      "@typescript-eslint/consistent-type-imports": "error",
      eqeqeq: ["error", "always"],
    },
  },
);

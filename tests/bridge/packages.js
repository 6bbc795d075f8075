// The npm packages the bridge/export tests check against (scripts/bootstrap installs them into
// tests/bridge/node_modules). A missing one fails the test with the reason: never a silent pass.
const path = require("path");
const names = require("./package.json").dependencies;
const loaded = {};
for (const name of Object.keys(names)) {
  try {
    loaded[name] = require(require.resolve(name, { paths: [path.join(__dirname, "node_modules")] }));
  } catch (e) {
    console.error(`FAILED: npm package ${name} is not installed in ${path.join(__dirname, "node_modules")} ` +
      `(scripts/bootstrap installs it from the npm registry; was the registry reachable?): ${e.message.split("\n")[0]}`);
    process.exit(1);
  }
}
module.exports = loaded;

// Foxglove's published JSON Schema of `name` ("foxglove.SceneUpdate"), from @foxglove/schemas.
module.exports.publishedSchema = (name) => {
  const schemas = require(require.resolve("@foxglove/schemas/jsonschema", { paths: [path.join(__dirname, "node_modules")] }));
  const s = schemas[name.replace(/^foxglove\./, "")];
  if (!s) throw new Error(`@foxglove/schemas has no ${name}`);
  return s;
};

// A schema without its prose (descriptions, comments), keys sorted: what must match exactly.
module.exports.shape = function shape(o) {
  if (Array.isArray(o)) return o.map(shape);
  if (o && typeof o === "object") {
    const r = {};
    for (const k of Object.keys(o).sort()) if (k !== "description" && k !== "$comment") r[k] = shape(o[k]);
    return r;
  }
  return o;
};

module.exports.check = (cond, what) => {
  if (!cond) throw new Error(what);
};

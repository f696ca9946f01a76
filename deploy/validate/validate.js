// Validates Kubernetes objects offline against the OpenAPI schemas of the
// Kubernetes version that kubernetes-models bundles (package.json pins it;
// docs/deploy.md names the version), as `kubectl apply --validate=strict`
// would against an API server of that version, without one:
//
//  1. the schema: types, required fields, enums, formats (kubernetes-models'
//     compiled validators);
//  2. unknown fields: the schemas leave objects open, but an API server with
//     strict field validation refuses a field it does not know (a typo such
//     as `readinesProbe` would otherwise pass); every field is looked up in
//     the model's declared properties, down through the nested types.
//
// Input on stdin: JSON, {"documents": [{"file": F, "index": I, "object": O}]}
// (scripts/manifest-validate.sh converts the YAML). Prints one line per
// object, every error with its file, document and path; exits 1 on any.
"use strict";
const fs = require("fs");
const path = require("path");

const MODELS = path.dirname(require.resolve("kubernetes-models/package.json"));
const APIMACHINERY = path.dirname(require.resolve("@kubernetes-models/apimachinery/package.json"));

// apiVersion "apps/v1" -> directory "apps/v1"; core "v1" -> "v1".
function modelFile(apiVersion, kind) {
  return path.join(MODELS, apiVersion, kind);
}

// ---- the declared properties of each interface, read from the .d.ts files
const interfaces = new Map(); // "file#Interface" -> {props: Map(name -> type text), file}

function resolveImport(fromFile, spec) {
  if (spec.startsWith("@kubernetes-models/apimachinery/")) {
    return path.join(APIMACHINERY, spec.slice("@kubernetes-models/apimachinery/".length));
  }
  if (spec.startsWith("kubernetes-models/")) return path.join(MODELS, spec.slice("kubernetes-models/".length));
  return path.resolve(path.dirname(fromFile), spec);
}

function parseDts(file) {
  const text = fs.readFileSync(file + ".d.ts", "utf8");
  const imports = new Map();
  for (const m of text.matchAll(/^import \{ ([^}]+) \} from "([^"]+)";/gm)) {
    for (const name of m[1].split(",").map((s) => s.trim())) imports.set(name, resolveImport(file, m[2]));
  }
  const result = new Map();
  for (const m of text.matchAll(/^export interface (\w+)(?: extends [^{]+)? \{\n([\s\S]*?)^\}/gm)) {
    const props = new Map();
    // One property a line at four spaces ("name"?: Type;); an object type
    // goes on over the next lines ({ ... }) and is not descended into.
    for (const p of m[2].matchAll(/^ {4}"([^"]+)"\??: (.*)$/gm)) props.set(p[1], p[2].replace(/;$/, ""));
    result.set(m[1], { props, imports, file });
  }
  return result;
}

function lookupInterface(file, name) {
  const key = file + "#" + name;
  if (interfaces.has(key)) return interfaces.get(key);
  let found = null;
  try {
    const all = parseDts(file);
    // A model file declares I<Kind> (the data) and an IIo... alias of it.
    found = all.get(name) || null;
  } catch (e) {
    found = null;
  }
  interfaces.set(key, found);
  return found;
}

// The interface a type text names, if it is one: "IIoK8sApiCoreV1Probe" or
// "Array<IIoK8sApiCoreV1Probe>" -> {iface, array}.
function typeTarget(owner, typeText) {
  let t = typeText.trim();
  let array = false;
  const arr = /^Array<(.+)>$/.exec(t);
  if (arr) { t = arr[1].trim(); array = true; }
  if (!/^I\w+$/.test(t)) return null;
  const file = owner.imports.get(t);
  if (!file) return null;
  // The imported file declares the interface under its short name (ISpec)
  // and exports the long one as an alias of it: find the one with props.
  let iface = lookupInterface(file, t);
  if (!iface) {
    const short = "I" + path.basename(file);
    iface = lookupInterface(file, short);
  }
  return iface ? { iface, array } : null;
}

function checkFields(value, iface, where, errors) {
  if (value === null || typeof value !== "object" || Array.isArray(value)) return;
  for (const [key, v] of Object.entries(value)) {
    if (!iface.props.has(key)) {
      errors.push(`${where}/${key}: unknown field "${key}"`);
      continue;
    }
    const target = typeTarget(iface, iface.props.get(key));
    if (!target) continue;
    if (target.array) {
      if (Array.isArray(v)) v.forEach((item, i) => checkFields(item, target.iface, `${where}/${key}/${i}`, errors));
    } else {
      checkFields(v, target.iface, `${where}/${key}`, errors);
    }
  }
}

function validate(doc) {
  const { file, index, object } = doc;
  const label = `${file} [document ${index}]`;
  if (object === null || typeof object !== "object" || Array.isArray(object)) {
    return [`${label}: not an object`];
  }
  const { apiVersion, kind } = object;
  if (typeof apiVersion !== "string" || typeof kind !== "string") {
    return [`${label}: apiVersion and kind are required strings`];
  }
  const name = object.metadata && object.metadata.name;
  const what = `${label} ${apiVersion} ${kind} "${name}"`;
  let Model;
  try {
    Model = require(modelFile(apiVersion, kind))[kind];
  } catch (e) {
    return [`${what}: no schema for ${apiVersion} ${kind} in Kubernetes ${K8S_VERSION}`];
  }
  if (!Model) return [`${what}: no schema for ${apiVersion} ${kind}`];
  const errors = [];
  try {
    new Model(object).validate();
  } catch (e) {
    for (const line of String(e.message).split("\n")) {
      if (line.trim()) errors.push(`${what}: ${line.trim().replace(/^data\//, "/")}`);
    }
  }
  if (typeof name !== "string" || name === "") errors.push(`${what}: metadata.name is required`);
  const root = lookupInterface(modelFile(apiVersion, kind), "I" + kind);
  if (!root) {
    errors.push(`${what}: cannot read the declared fields of ${kind}`);
  } else {
    const unknown = [];
    // TypeMeta's fields (apiVersion, kind) are declared by extension.
    root.props.set("apiVersion", "string");
    root.props.set("kind", "string");
    checkFields(object, root, "", unknown);
    for (const u of unknown) errors.push(`${what}: ${u}`);
  }
  return errors.length ? errors : null;
}

const pkg = JSON.parse(fs.readFileSync(path.join(__dirname, "package.json"), "utf8"));
const K8S_VERSION = pkg.kubernetesVersion;
const input = JSON.parse(fs.readFileSync(0, "utf8"));
let failed = 0;
for (const doc of input.documents) {
  const errors = validate(doc);
  const o = doc.object || {};
  const head = `${doc.file} [document ${doc.index}] ${o.apiVersion} ${o.kind} "${o.metadata && o.metadata.name}"`;
  if (errors) {
    failed++;
    for (const e of errors) console.log(`INVALID ${e}`);
  } else {
    console.log(`valid   ${head}`);
  }
}
const models = JSON.parse(fs.readFileSync(path.join(MODELS, "package.json"), "utf8")).version;
console.log(`${input.documents.length} objects, ${failed} invalid (Kubernetes ${K8S_VERSION} schemas, kubernetes-models ${models})`);
process.exit(failed ? 1 : 0);

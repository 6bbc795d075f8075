// Every code block of a doc that follows "<!-- snippet: PATH -->" must be a verbatim excerpt of PATH
// (relative to the repository root), so the docs show code that CI builds and tests.
//   node check_doc_snippets.js REPO_ROOT DOC.md
const fs = require("fs");
const path = require("path");
const [root, doc] = process.argv.slice(2);
const text = fs.readFileSync(doc, "utf8");
const pattern = /<!-- snippet: (\S+) -->\n```[a-z]*\n([\s\S]*?)\n```/g;
let count = 0, bad = 0;
for (const m of text.matchAll(pattern)) {
  count++;
  const file = path.join(root, m[1]);
  if (!fs.existsSync(file)) { console.error(`${doc}: snippet ${count} names ${m[1]}, which does not exist`); bad++; continue; }
  if (!fs.readFileSync(file, "utf8").includes(m[2])) {
    const line = text.slice(0, m.index).split("\n").length;
    console.error(`${doc}:${line}: snippet ${count} is not an excerpt of ${m[1]} any more; copy it again from the file`);
    bad++;
  }
}
if (count === 0) { console.error(`${doc}: no snippets found`); process.exit(1); }
console.log(`${doc}: ${count - bad} of ${count} snippets match their files`);
process.exit(bad ? 1 : 0);

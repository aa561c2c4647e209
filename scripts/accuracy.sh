#!/usr/bin/env bash
# Regenerates docs/accuracy/ with `murk converge` and `murk check-stability` on the demo
# cloud, then copies their tables into docs/how-it-works.md between the `accuracy:`
# markers, so every number in its Accuracy section comes from the commands.
#
#   scripts/accuracy.sh            (from the repository root; builds murk in release)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
murk=target/release/murk
out=docs/accuracy
mkdir -p "$out"
"$murk" converge fixtures/cloud.vdb --out "$out" --quiet >/dev/null
# Exit status 1 (a failed case) still updates the table: the docs must show it.
"$murk" check-stability --out "$out" >"$out/stability.txt" || true
python3 - "$out" <<'PY'
import re, sys, pathlib
out = pathlib.Path(sys.argv[1])
md = (out / "converge.md").read_text()
summary = md.split("## Summary\n\n", 1)[1].split("\n## ", 1)[0].strip()
rows = md.split("## Every render\n\n", 1)[1].split("\n![", 1)[0].strip()
intro = md.split("\n\n", 2)[1].strip()
stability = "\n".join(l for l in (out / "stability.txt").read_text().splitlines() if l.startswith("|"))
readme = pathlib.Path("docs/how-it-works.md")
text = readme.read_text()
for name, body in [("converge-intro", intro), ("converge-summary", summary),
                   ("converge-rows", rows), ("stability", stability)]:
    pattern = re.compile(r"(<!-- accuracy:%s -->\n).*?(<!-- /accuracy:%s -->)" % (name, name), re.S)
    if not pattern.search(text):
        sys.exit("docs/how-it-works.md has no accuracy:%s markers" % name)
    text = pattern.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)
readme.write_text(text)
PY
echo "updated $out and docs/how-it-works.md"

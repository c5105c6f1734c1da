#!/usr/bin/env bash
# The planning repo's CI step: are the agreed views of this week's model still as agreed?
#
#   ./ci.sh                                  checks model/rev2 (the new export) against baseline/
#   MODEL=model/rev1/scene.toml ./ci.sh      checks another revision
#
# Exit 0: every view within tolerance; 1: a view changed (report/report.html and report/junit.xml
# name the views and the elements under the changed pixels); 2: bad input (no baseline, say).
# The baseline is recorded once from the agreed revision, looked at, and committed:
#   mrcheck regress record model/rev1/scene.toml -o baseline/
set -uo pipefail
cd "$(dirname "$0")"
model=${MODEL:-model/rev2/scene.toml}
if [[ ! -f baseline/baseline.json ]]; then
    echo "ci.sh: no baseline/ yet; record it from the agreed revision and commit it:" >&2
    echo "  mrcheck regress record model/rev1/scene.toml -o baseline/" >&2
    exit 2
fi
mrcheck regress check "$model" --baseline baseline/ -o report/
status=$?
# the CI keeps report/ as an artifact and reads report/junit.xml into its test tab
echo "ci.sh: mrcheck regress check exited $status; open report/report.html" >&2
exit $status

# browser.sh - sourced by the browser tests (run_viewer.sh, run_params.sh): sets `web` to the
# viewer's folder and exits 77 (skip) unless node, chromium and the viewer's npm packages are there.
here=$(cd "$(dirname "$0")" && pwd)
web=${MESHSTEER_SRC:-$here/../../..}/clients/web
command -v node >/dev/null || { echo "skip: node not installed"; exit 77; }
[ -x "${CHROMIUM:-/usr/bin/chromium}" ] || { echo "skip: chromium not installed"; exit 77; }
[ -f "$web/node_modules/three/build/three.module.js" ] && [ -d "$web/node_modules/playwright-core" ] ||
    { echo "skip: run 'npm ci' in clients/web (scripts/run.sh does)"; exit 77; }

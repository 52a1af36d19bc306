#!/usr/bin/env bash
# Black-box test of the `cadinterp` tool:
#   cli_test.sh CADINTERP CASES_DIR WORK_DIR [ANALYTIC_HOST_SO]
# CASES_DIR is conformance/cases (small committed assets); WORK_DIR is scratch. With the builder
# linked, `build` runs too: with the built-in analytic host if there is one, and by dlopen of
# ANALYTIC_HOST_SO if given.
set -u
CLI=$1
CASES=$2
WORK=$3
HOST_SO=${4:-}
CHECK="python3 $(dirname "$0")/check_exports.py"
VALID=$CASES/valid
rm -rf "$WORK" && mkdir -p "$WORK"

failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

# run EXPECTED_EXIT NAME -- ARGS...: runs the tool, keeps stdout/stderr in $WORK/NAME.{out,err}.
run() {
  local expected=$1 name=$2
  shift 3
  "$CLI" "$@" >"$WORK/$name.out" 2>"$WORK/$name.err"
  local rc=$?
  if [ "$rc" -ne "$expected" ]; then
    fail "$name: exit $rc, expected $expected: cadinterp $*"
    sed 's/^/    /' "$WORK/$name.err" | head -20
    return 1
  fi
  return 0
}

# contains NAME out|err TEXT: the captured output holds TEXT.
contains() {
  if ! grep -qF -- "$3" "$WORK/$1.$2"; then
    fail "$1: std$2 lacks '$3'"
    sed 's/^/    /' "$WORK/$1.$2" | head -20
  fi
}

json_get() {  # json_get FILE PYTHON_EXPR (d is the parsed document)
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print($2)" "$1"
}

# ---- help ---------------------------------------------------------------------------------------
run 0 help -- --help && contains help out "commands:"
run 0 help_cmd -- help eval && contains help_cmd out "usage: cadinterp eval"
run 2 no_args -- && contains no_args err "usage: cadinterp COMMAND"
run 0 version -- --version && contains version out "asset format"
for c in build inspect eval bench explore; do
  run 0 "help_$c" -- $c --help && contains "help_$c" out "usage: cadinterp $c" &&
    contains "help_$c" out "--help"
done
contains help_build out "--geometry-tol"
contains help_build out "--store"
contains help_build out "--calling-thread"
contains help_eval out "--gltf"
contains help_bench out "--iterations"

# ---- usage errors: exit 2 and a message ---------------------------------------------------------
A2=$VALID/k2_linear/asset.cadi
run 2 u_command -- frobnicate && contains u_command err "unknown command 'frobnicate'"
run 2 u_option -- eval "$A2" 0.5 0.5 --feilds temperature && contains u_option err "did you mean --fields"
run 2 u_missing -- inspect && contains u_missing err "missing argument ASSET"
run 2 u_extra -- inspect "$A2" extra && contains u_extra err "unexpected argument 'extra'"
run 2 u_arity -- eval "$A2" 0.5 && contains u_arity err "the asset has 2 parameters (bend, twist); got 1 value"
run 2 u_number -- eval "$A2" 0.5 abc && contains u_number err "parameter 2 (twist) must be a finite number, got 'abc'"
run 2 u_nan -- eval "$A2" 0.5 nan && contains u_nan err "must be a finite number"
run 2 u_field -- eval "$A2" 0.5 0.5 --fields nope && contains u_field err "unknown field 'nope'"
run 2 u_direction -- eval "$A2" 0.5 0.5 --direction 0,0,0 && contains u_direction err "zero vector"
run 2 u_iterations -- bench "$A2" --iterations 0 && contains u_iterations err "--iterations must be in [1,"
run 2 u_int -- bench "$A2" --iterations ten && contains u_int err "--iterations expects an integer, got 'ten'"
run 2 u_value -- bench "$A2" --iterations && contains u_value err "needs a value"
run 2 u_twice -- inspect "$A2" --json --json && contains u_twice err "given twice"
run 2 u_required -- build -o "$WORK/x.cadi" && contains u_required err "missing required option --host"
run 2 u_degree -- build --host x.so --degree 2 -o "$WORK/x.cadi" && contains u_degree err "--degree must be one of 1|3, got '2'"
run 2 u_tol -- build --host x.so --geometry-tol -1 -o "$WORK/x.cadi" && contains u_tol err "--geometry-tol must be in"
contains u_number err "(see 'cadinterp eval --help')"

# ---- runtime errors: exit 1, the status named ---------------------------------------------------
run 1 r_missing -- inspect "$WORK/none.cadi" && contains r_missing err "CADINTERP_E_IO"
run 1 r_magic -- inspect "$CASES/invalid/bad_magic/asset.cadi" && contains r_magic err "CADINTERP_E_BAD_MAGIC"
run 1 r_version -- eval "$CASES/invalid/unknown_required_feature/asset.cadi" 0.5 &&
  contains r_version err "CADINTERP_E_UNSUPPORTED_VERSION" &&
  contains r_version err "conformance_unknown_feature"
run 1 r_outside -- eval "$A2" 0.5 1.5 && contains r_outside err "CADINTERP_E_OUTSIDE_DOMAIN" &&
  contains r_outside err "twist = 1.5 is outside [0, 1]"
run 1 r_negative -- eval "$A2" -0.5 0.5 && contains r_negative err "bend = -0.5 is outside"
run 1 r_infeasible -- eval "$VALID/k2_infeasible/asset.cadi" 0.95 0.95 &&
  contains r_infeasible err "CADINTERP_E_INFEASIBLE"
run 1 r_checksum -- eval "$CASES/invalid/blob_checksum/asset.cadi" 0 &&
  contains r_checksum err "CADINTERP_E_CHECKSUM"
run 1 r_export -- eval "$A2" 0.5 0.5 --obj "$WORK/no/such/dir/x.obj" && contains r_export err "cannot open"

# ---- inspect ------------------------------------------------------------------------------------
for dir in "$VALID"/*/; do
  name=$(basename "$dir")
  if run 0 "inspect_$name" -- inspect "$dir/asset.cadi"; then
    contains "inspect_$name" out "parameters"
    contains "inspect_$name" out "blobs"
  fi
  if run 0 "inspectj_$name" -- inspect "$dir/asset.cadi" --json; then
    python3 -m json.tool "$WORK/inspectj_$name.out" >/dev/null || fail "inspect --json $name: invalid JSON"
    # Counts agree with the runtime's view of the same asset (eval --json at the box centre).
    python3 - "$WORK/inspectj_$name.out" <<'EOF' || fail "inspect --json $name: inconsistent"
import json, sys
d = json.load(open(sys.argv[1]))
t = d["tree"]
assert t["elements"] >= 1 and t["samples"] >= 2 and len(d["parameters"]) >= 1
assert len(t["depth"]) == len(d["parameters"])
assert t["infeasible_elements"] == len(t["infeasible"])
assert d["file_bytes"] == d["header_bytes"] + d["index_bytes"] + d["blob_bytes"]
assert sum(b["bytes"] for b in d["blobs"]) == d["blob_bytes"]
pos = sum(b["references"] for b in d["blobs"] if b["kind"] == "positions")
assert all(b["count"] <= b["references"] for b in d["blobs"])
assert pos == t["stored_meshes"], (pos, t["stored_meshes"])
assert d["degree"] in (1, 3)
EOF
  fi
done
contains inspect_k2_cubic out "degree 3"
contains inspect_k3_linear out "meshopt"
contains inspect_k4_linear out "draco"
contains inspect_k2_infeasible out "infeasible elements:"
contains inspect_k2_linear out "temperature"
contains inspect_k2_linear out "tip load"
[ "$(json_get "$WORK/inspectj_k2_linear.out" 'd["parameters"][1]["name"]')" = twist ] ||
  fail "inspect --json: parameter name"
# Field units (format 1.1): shown when the asset has them, "" in a 1.0 asset.
contains inspect_k1_units out "[MPa]"
[ "$(json_get "$WORK/inspectj_k1_units.out" '",".join(f["unit"] for f in d["fields"])')" = "K,MPa" ] ||
  fail "inspect --json: field units of k1_units"
[ "$(json_get "$WORK/inspectj_k1_units.out" 'd["format"]')" = "1.1" ] ||
  fail "inspect --json: k1_units is format 1.1"
[ "$(json_get "$WORK/inspectj_k2_linear.out" '",".join(f["unit"] for f in d["fields"])')" = "," ] ||
  fail "inspect --json: a 1.0 asset's fields have no unit"

# ---- eval and exports ---------------------------------------------------------------------------
if run 0 eval_text -- eval "$A2" 0.3 0.7 --grad; then
  contains eval_text out "element"
  contains eval_text out "volume"
  contains eval_text out "frontal area"
  contains eval_text out "d/d twist"
fi
if run 0 eval_json -- eval "$A2" 0.3 0.7 --grad --json \
  --vtu "$WORK/m.vtu" --obj "$WORK/m.obj" --gltf "$WORK/m.gltf"; then
  python3 -m json.tool "$WORK/eval_json.out" >/dev/null || fail "eval --json: invalid JSON"
  J=$WORK/eval_json.out
  V=$(json_get "$J" 'd["vertices"]')
  T=$(json_get "$J" 'd["tets"]')
  F=$(json_get "$J" 'd["triangles"]')
  json_get "$J" 'd["properties"]["volume"] > 0 and d["properties"]["area"] > 0 and len(d["gradient"]) == 2' |
    grep -qx True || fail "eval --json: properties"
  SV=$(json_get "$J" '[e["vertices"] for e in d["exports"] if e["format"] == "obj"][0]')
  $CHECK vtu "$WORK/m.vtu" --vertices "$V" --cells "$T" || fail "vtu (base64) invalid"
  $CHECK obj "$WORK/m.obj" --vertices "$SV" --triangles "$F" || fail "obj invalid"
  $CHECK gltf "$WORK/m.gltf" --vertices "$SV" --triangles "$F" || fail "gltf invalid"
fi
# Cubic, 3 parameters, ASCII VTU, binary glTF, one field only.
A3=$VALID/k3_cubic/asset.cadi
if run 0 eval3 -- eval "$A3" 0.2 0.4 0.6 --fields temperature --json --ascii \
  --vtu "$WORK/c.vtu" --gltf "$WORK/c.glb" --obj "$WORK/c.obj"; then
  J=$WORK/eval3.out
  V=$(json_get "$J" 'd["vertices"]')
  T=$(json_get "$J" 'd["tets"]')
  F=$(json_get "$J" 'd["triangles"]')
  SV=$(json_get "$J" '[e["vertices"] for e in d["exports"] if e["format"] == "gltf"][0]')
  [ "$(json_get "$J" 'len(d["fields"])')" = 1 ] || fail "eval --fields: one field expected"
  grep -q 'format="ascii"' "$WORK/c.vtu" || fail "--ascii VTU is not ASCII"
  $CHECK vtu "$WORK/c.vtu" --vertices "$V" --cells "$T" || fail "vtu (ascii) invalid"
  $CHECK gltf "$WORK/c.glb" --vertices "$SV" --triangles "$F" || fail "glb invalid"
  $CHECK obj "$WORK/c.obj" --vertices "$SV" --triangles "$F" || fail "obj (k3) invalid"
fi
# The checker must be able to fail: a truncated glb and a wrong count are rejected.
if [ -f "$WORK/c.glb" ]; then
  head -c 100 "$WORK/c.glb" >"$WORK/bad.glb"
  $CHECK gltf "$WORK/bad.glb" --vertices 1 --triangles 1 2>/dev/null && fail "checker accepted a truncated glb"
  $CHECK vtu "$WORK/c.vtu" --vertices 1 --cells 1 2>/dev/null && fail "checker accepted wrong VTU counts"
fi

# ---- bench --------------------------------------------------------------------------------------
if run 0 bench -- bench "$A2" --iterations 20; then
  for row in "open" "eval, cold" "eval, warm" "eval+grad" "vjp" "properties+grad"; do
    contains bench out "$row"
  done
fi

# ---- build (needs the builder and a host) -------------------------------------------------------
build_with() {  # build_with TAG HOST
  local tag=$1 host=$2 out=$WORK/$1.cadi store=$WORK/$1.store
  local opts=(build --host "$host" --model bracket --host-options cells=1 --max-samples 12
    --max-depth 2 --threads 2 --store "$store" -o "$out")
  if run 0 "build_$tag" -- "${opts[@]}"; then
    for row in "samples" "elements" "stored meshes" "per sample" "asset"; do
      contains "build_$tag" out "$row"
    done
    run 0 "build_${tag}_inspect" -- inspect "$out" --json &&
      python3 -m json.tool "$WORK/build_${tag}_inspect.out" >/dev/null || fail "inspect of a built asset"
    # Every field has its estimates, measured on the elements the geometry's were (format 1.3).
    python3 - "$WORK/build_${tag}_inspect.out" <<'EOF' || fail "inspect $tag: field error estimates"
import json, sys
d = json.load(open(sys.argv[1]))
e = d["error_estimate"]
assert e["measured"] > 0, e
assert [f["name"] for f in e["fields"]] == [f["name"] for f in d["fields"]], e
for f in e["fields"]:
    assert f["measured"] == e["measured"] and 0 <= f["min"] <= f["mean"] <= f["max"], f
EOF
    # Evaluate at the centre of the box the asset declares.
    local x
    x=$(json_get "$WORK/build_${tag}_inspect.out" \
      '" ".join(repr((p["lower"] + p["upper"]) / 2) for p in d["parameters"])')
    # shellcheck disable=SC2086
    run 0 "build_${tag}_eval" -- eval "$out" $x --obj "$WORK/$tag.obj" && contains "build_${tag}_eval" out "volume"
    # Resuming from the store evaluates nothing again and writes the same bytes.
    cp "$out" "$WORK/$tag.first.cadi"
    if run 0 "build_${tag}_resume" -- "${opts[@]}"; then
      contains "build_${tag}_resume" out "host evaluations 0"
      cmp -s "$out" "$WORK/$tag.first.cadi" || fail "build $tag: resumed build is not byte-identical"
    fi
  fi
}
if grep -q "^builder: yes" "$WORK/version.out"; then
  run 2 u_host -- build --host nosuchhost -o "$WORK/x.cadi" && contains u_host err "unknown host 'nosuchhost'"
  run 1 r_host -- build --host "$WORK/missing.so" -o "$WORK/x.cadi" && contains r_host err "cannot load host library"
  if grep -q "^built-in hosts:.*analytic" "$WORK/version.out"; then
    build_with builtin analytic
    # The points where the host failed, with its message, are listed by inspect.
    if run 0 build_fail -- build --host analytic --model bracket --host-options cells=1,fail_region=1 \
      --max-samples 12 --max-depth 2 --threads 2 -o "$WORK/fail.cadi"; then
      run 0 build_fail_inspect -- inspect "$WORK/fail.cadi" &&
        contains build_fail_inspect out "infeasible points recorded:" &&
        contains build_fail_inspect out "fail_region"
      run 0 build_fail_inspectj -- inspect "$WORK/fail.cadi" --json &&
        [ "$(json_get "$WORK/build_fail_inspectj.out" \
          'all(len(p["x"]) == len(d["parameters"]) and "fail_region" in p["message"] for p in d["infeasible_points"]) and len(d["infeasible_points"]) > 0')" = True ] ||
        fail "inspect --json: infeasible points of a build with a fail region"
    fi
    # The host called from the main thread only: the threaded build's bytes.
    run 0 build_ct -- build --host analytic --model bracket --host-options cells=1,fail_region=1 \
      --max-samples 12 --max-depth 2 --calling-thread -o "$WORK/fail_ct.cadi" &&
      { cmp -s "$WORK/fail.cadi" "$WORK/fail_ct.cadi" || fail "build --calling-thread: not the threaded build's bytes"; }
    run 1 r_model -- build --host analytic --model nosuchmodel -o "$WORK/x.cadi" &&
      contains r_model err "refused model 'nosuchmodel'"
  else
    echo "note: no built-in analytic host in this build"
  fi
  if [ -n "$HOST_SO" ]; then
    build_with dlopen "$HOST_SO"
  else
    echo "note: no analytic host library given; build by dlopen not tested"
  fi
else
  echo "note: built without the builder; build not tested"
fi

# ---- explore (the embedded HTTP server; the page itself is tested by scripts/test-explorer.sh) ----
if ! grep -q "built without" "$WORK/help_explore.out"; then
  contains help_explore out "--web-root"
  contains help_explore out "--port"
  mkdir -p "$WORK/web/assets" "$WORK/wasm"
  echo '<!doctype html><title>explorer</title>' >"$WORK/web/index.html"
  echo 'export const x = 1;' >"$WORK/web/assets/main.js"
  echo 'export async function load() {}' >"$WORK/wasm/cadinterp.mjs"
  echo 'export default function () {}' >"$WORK/wasm/cadinterp_wasm.mjs"
  printf '\0asm\1\0\0\0' >"$WORK/wasm/cadinterp_wasm.wasm"
  SERVE=(--port 0 --web-root "$WORK/web" --wasm-dir "$WORK/wasm")
  run 1 r_explore_checksum -- explore "$CASES/invalid/blob_checksum/asset.cadi" "${SERVE[@]}" &&
    contains r_explore_checksum err "invalid asset" && contains r_explore_checksum err "CADINTERP_E_CHECKSUM"
  run 1 r_explore_magic -- explore "$CASES/invalid/bad_magic/asset.cadi" "${SERVE[@]}" &&
    contains r_explore_magic err "CADINTERP_E_BAD_MAGIC"
  run 1 r_explore_missing -- explore "$WORK/none.cadi" "${SERVE[@]}" && contains r_explore_missing err "CADINTERP_E_IO"
  run 2 u_explore_port -- explore "$A2" --port 70000 && contains u_explore_port err "--port must be in [0, 65535]"
  run 1 r_explore_noweb -- explore "$A2" --port 0 --web-root "$WORK/nowhere" --wasm-dir "$WORK/wasm" &&
    contains r_explore_noweb err "explorer page is not built"
  run 1 r_explore_nowasm -- explore "$A2" --port 0 --web-root "$WORK/web" --wasm-dir "$WORK/nowhere" &&
    contains r_explore_nowasm err "WebAssembly runtime is missing"
  # Serves the page, the runtime and the asset's exact bytes with the right types; a second server
  # on the same port fails cleanly; SIGINT stops the first with exit 0.
  python3 - "$CLI" "$A2" "$WORK" <<'EOF' || fail "explore: serving"
import json, re, signal, subprocess, sys, urllib.error, urllib.parse, urllib.request
cli, asset, work = sys.argv[1:4]
p = subprocess.Popen([cli, "explore", asset, "--port", "0", "--web-root", work + "/web",
                      "--wasm-dir", work + "/wasm"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                     text=True)
try:
    url = None
    for line in p.stdout:
        m = re.search(r"(http://127\.0\.0\.1:(\d+)/)", line)
        if m:
            url, port = m.group(1), m.group(2)
            break
    assert url, "no URL printed"
    def get(path):
        try:
            with urllib.request.urlopen(url + path, timeout=10) as r:
                return r.status, r.headers.get("Content-Type", ""), r.read()
        except urllib.error.HTTPError as e:
            return e.code, "", b""
    st, ct, body = get("")
    assert st == 200 and ct.startswith("text/html") and b"explorer" in body, (st, ct)
    st, ct, _ = get("assets/main.js")
    assert st == 200 and ct.startswith("text/javascript"), (st, ct)
    st, ct, _ = get("wasm/cadinterp.mjs")
    assert st == 200 and ct.startswith("text/javascript"), (st, ct)
    st, ct, body = get("wasm/cadinterp_wasm.wasm")
    assert st == 200 and ct == "application/wasm" and body == b"\0asm\1\0\0\0", (st, ct)
    st, ct, body = get("api/asset.cadi")
    assert st == 200 and ct == "application/octet-stream", (st, ct)
    assert body == open(asset, "rb").read(), "served bytes differ from the file"
    st, ct, body = get("api/asset.json")
    d = json.loads(body)
    # The optimization endpoint (explore_optimize.h): 501 without Ipopt, else it runs.
    def optimize(fields=None):
        data = urllib.parse.urlencode(fields, doseq=True).encode() if fields else None
        try:
            with urllib.request.urlopen(url + "api/optimize", data=data, timeout=60) as r:
                return r.status, json.loads(r.read())
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read())
    st, avail = optimize()
    if st == 200:
        assert avail["available"] is True, avail
        st, o = optimize({"objective": "volume", "constraint": ["volume >= 0.1"],
                          "fix": "twist=0.25", "start": "0.5,0.25"})
        assert st == 200 and o["parameters"] == ["bend", "twist"], (st, o)
        assert o["result"]["x"]["twist"] == 0.25 and len(o["result"]["path"]) >= 1, o
        assert o["result"]["constraints"][0]["value"] >= 0.1 - 1e-6, o
        st, o = optimize({"objective": "volume + 0.1*mas"})
        assert st == 400 and o["input"] == "objective" and o["column"] == 14, (st, o)
        assert "unknown quantity 'mas'" in o["error"], o
        st, o = optimize({"objective": "volume", "max_iterations": "100000"})
        assert st == 400 and o["input"] == "max_iterations", (st, o)
    else:
        assert st == 501 and avail["available"] is False and "Ipopt" in avail["reason"], (st, avail)
    assert d["name"] == "asset.cadi" and d["bytes"] == len(open(asset, "rb").read()), d
    assert d["parameters"] == 2 and d["verified_elements"] == d["feasible_elements"] >= 1, d
    assert get("no/such/file.js")[0] == 404
    assert get("../../../../etc/passwd")[0] != 200
    second = subprocess.run([cli, "explore", asset, "--port", port, "--web-root", work + "/web",
                             "--wasm-dir", work + "/wasm"], capture_output=True, text=True, timeout=30)
    assert second.returncode == 1 and "cannot listen" in second.stderr, second.stderr
finally:
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=20)
assert p.returncode == 0, (p.returncode, err)
assert "stopped" in out, out
EOF
fi

# ---- optimize (needs libcadinterp_optimize, i.e. Ipopt) -------------------------------------------
if run 0 help_optimize -- optimize --help && ! grep -q "built without" "$WORK/help_optimize.out"; then
  # The synthetic box: its volume grows with bend (parameter 0); stress is a per-tet field.
  run 0 opt_text -- optimize "$A2" --minimize 'integral(stress) + 0.5*volume' \
    --subject-to 'volume <= 0.125' --fix twist=0.25 && contains opt_text out "status:" &&
    contains opt_text out "x*:" && contains opt_text out "linear asset" &&
    contains opt_text err "start 0 iter   0"
  if run 0 opt_json -- optimize "$A2" --minimize 'max(temperature, ks=5)' --multistart 3 --json; then
    [ "$(json_get "$WORK/opt_json.out" 'd["starts"]')" = 3 ] || fail "opt_json: starts != 3"
    [ "$(json_get "$WORK/opt_json.out" 'len(d["path"]) > 0')" = True ] || fail "opt_json: no path"
  fi
  run 2 opt_syntax -- optimize "$A2" --minimize 'integral(stress) + 0.1*mas' &&
    contains opt_syntax err "column 24: unknown quantity 'mas'"
  run 2 opt_field -- optimize "$A2" --minimize 'integral(von_mises)' &&
    contains opt_field err "the asset has no field 'von_mises'"
  run 2 opt_fix -- optimize "$A2" --minimize volume --fix size=1 &&
    contains opt_fix err "no parameter 'size' (it has bend, twist)"
  # The infeasible corner is a wall: a start inside it is refused, a run ends outside it.
  run 1 opt_wall_start -- optimize "$VALID/k2_infeasible/asset.cadi" --minimize volume \
    --start 0.95,0.95 && contains opt_wall_start err "CADINTERP_E_INFEASIBLE"
fi

# ---- optimize --verify: the optimum re-simulated by the host library ---------------------------
if [ -n "$HOST_SO" ] && grep -q -- "--verify" "$WORK/help_optimize.out" &&
   run 0 verify_plate_build -- build --host "$HOST_SO" --model plate --host-options edge=10 \
     --max-samples 60 --threads 1 -q -o "$WORK/plate.cadi"; then
  VH=(--verify --host "$HOST_SO" --model plate --host-options edge=10)
  OBJ='integral(von_mises)'
  CON=('volume >= 20000' 'max(von_mises) <= 1000' 'area <= 1e5')
  SUBJ=()
  for c in "${CON[@]}"; do SUBJ+=(--subject-to "$c"); done
  # The interpolation's accuracy on these functions: interpolated vs the host's values at six
  # points (no iterations: x* is the start), then at the optimum.
  i=0
  for start in 45,25,8 95,55,8 60,35,8 80,50,8 50,58,8 90,22,8; do
    run 0 "verify_cal$i" -- optimize "$WORK/plate.cadi" --minimize "$OBJ" "${SUBJ[@]}" \
      --fix thickness=8 --start "$start" --max-iterations 0 --json "${VH[@]}"
    i=$((i + 1))
  done
  run 0 verify_opt -- optimize "$WORK/plate.cadi" --minimize "$OBJ" "${SUBJ[@]}" \
    --fix thickness=8 --json "${VH[@]}"
  python3 - "$WORK" <<'PY' || fail "verify_opt: true values outside the interpolation's accuracy"
import json, sys
work = sys.argv[1]
def fns(name):
    d = json.load(open(f"{work}/{name}.out"))
    assert d["verify"]["feasible"], d["verify"]
    return d, d["verify"]["functions"]
eps = [0.0] * 4
for i in range(6):
    _, f = fns(f"verify_cal{i}")
    eps = [max(e, abs(g["true"] - g["interpolated"])) for e, g in zip(eps, f)]
d, f = fns("verify_opt")
L, W, T = d["x"]["length"], d["x"]["width"], d["x"]["thickness"]
# The host's plate is the box [0, L] x [0, W] x [0, T]: its true volume and area are closed forms.
assert abs(f[1]["true"] - L * W * T) <= 1e-5 * L * W * T, (f[1], L * W * T)
assert f[1]["true_meets_constraint"] == (f[1]["true"] >= 20000 * (1 - 1e-6)), f[1]
assert "true_meets_constraint" not in f[0], f[0]
area = 2 * (L * W + L * T + W * T)
assert abs(f[3]["true"] - area) <= 1e-5 * area, (f[3], area)
for e, g in zip(eps, f):
    err = abs(g["true"] - g["interpolated"])
    print(f'{g["expression"]}: interpolated {g["interpolated"]:.6g}, true {g["true"]:.6g}, '
          f'|difference| {err:.3g}, accuracy measured at 6 points {e:.3g}')
    assert err <= 3 * e + 1e-6 * abs(g["true"]), (g, e)
PY
  run 0 verify_text -- optimize "$WORK/plate.cadi" --minimize "$OBJ" --fix thickness=8 -q "${VH[@]}" &&
    contains verify_text out "true (host)" && contains verify_text out "minimize integral(von_mises)"
  # Brute-force grids: on the interpolant and on the host, against the plate's closed-form
  # volume L * W * T (the host's grid is exact; the interpolant's within its accuracy).
  run 0 inspect_plate -- inspect "$WORK/plate.cadi" --json &&
    run 0 grid_opt -- optimize "$WORK/plate.cadi" --minimize volume --subject-to 'volume >= 20000' \
      --fix thickness=8 --grid 9 --host-grid 3 -j 2 --json "${VH[@]}" &&
    python3 - "$WORK" <<'PY' || fail "grid_opt: grids disagree with the closed form"
import itertools, json, sys
work = sys.argv[1]
box = [(p["lower"], p["upper"]) for p in json.load(open(f"{work}/inspect_plate.out"))["parameters"]]
d = json.load(open(f"{work}/grid_opt.out"))
g, h = d["grid"], d["host_grid"]
assert g["points"] == 81 and h["points"] == 9 and h["not_evaluated"] == 0, (g, h)
def axis(lo, hi, n): return [lo + (hi - lo) * i / (n - 1) for i in range(n)]
vols = [L * W * 8 for L, W in itertools.product(axis(*box[0], 3), axis(*box[1], 3))]
best = min(v for v in vols if v >= 20000 * (1 - 1e-6))
assert abs(h["best_values"][0] - best) <= 1e-5 * best, (h, best)
assert h["violating"] == sum(v < 20000 * (1 - 1e-6) for v in vols), h
assert h["best_x"]["thickness"] == 8 and g["best_x"]["thickness"] == 8, (g, h)
assert g["found"] and g["best_values"][0] >= 20000 * (1 - 1e-6), g
# Ipopt's x* on the interpolant is no worse than the interpolant's own 9 x 9 grid.
assert d["objective"] <= g["best_values"][0] * (1 + 1e-4), (d["objective"], g)
PY
  run 0 grid_text -- optimize "$WORK/plate.cadi" --minimize volume --fix thickness=8 --grid 4 -q &&
    contains grid_text out "the interpolant, 4 per free parameter: 16 points"
  run 2 grid_one -- optimize "$WORK/plate.cadi" --minimize volume --grid 1 &&
    contains grid_one err "--grid must be in [2, 1000]"
  run 2 grid_huge -- optimize "$WORK/plate.cadi" --minimize volume --grid 1000 &&
    contains grid_huge err "more than 1000000 points"
  run 2 host_grid_no_host -- optimize "$WORK/plate.cadi" --minimize volume --host-grid 3 &&
    contains host_grid_no_host err "--verify and --host-grid need --host"
  # Failures, each before the optimization runs.
  run 1 verify_bad_path -- optimize "$WORK/plate.cadi" --minimize volume --verify \
    --host "$WORK/no/such/libhost.so" && contains verify_bad_path err "CADINTERP_E_IO" &&
    contains verify_bad_path err "cannot load host library"
  run 1 verify_bad_model -- optimize "$WORK/plate.cadi" --minimize volume --verify \
    --host "$HOST_SO" --model gear && contains verify_bad_model err "refused model 'gear'"
  run 2 verify_mismatch -- optimize "$WORK/plate.cadi" --minimize volume --verify \
    --host "$HOST_SO" --model bracket &&
    contains verify_mismatch err "the host has 4 parameters (length, height, thickness, bend_angle), the asset 3 (length, width, thickness)"
  # Same K, other names: a bracket asset checked with the foldplate.
  run 0 verify_bracket_build -- build --host "$HOST_SO" --model bracket --host-options cells=1 \
    --max-samples 16 --threads 1 -q -o "$WORK/bracket.cadi" &&
    run 2 verify_names -- optimize "$WORK/bracket.cadi" --minimize volume --verify \
      --host "$HOST_SO" --model foldplate &&
    contains verify_names err "the host has 4 parameters (length, width, thickness, fold), the asset 4 (length, height, thickness, bend_angle)"
  run 2 verify_no_host -- optimize "$WORK/plate.cadi" --minimize volume --verify &&
    contains verify_no_host err "--verify and --host-grid need --host"
  # A host that fails at x*: every true value is n/a with the host's reason.
  run 0 verify_fails -- optimize "$WORK/plate.cadi" --minimize volume --start 95,55,8 \
    --max-iterations 0 --json --verify --host "$HOST_SO" --model plate \
    --host-options edge=10,fail_region=1 &&
    [ "$(json_get "$WORK/verify_fails.out" \
      'd["verify"]["feasible"] is False and d["verify"]["functions"][0]["true"] is None and "fail" in d["verify"]["functions"][0]["reason"]')" = True ] ||
    fail "verify_fails: expected an infeasible verification with n/a values"
fi

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed (outputs in $WORK)"
  exit 1
fi
echo "all cadinterp CLI checks passed"

"""`cadinterp build --isolate` end to end on the faulty test host (examples/hosts/testing).

    isolate_test.py CADINTERP FAULTY_HOST_SO ANALYTIC_HOST_SO WORK_DIR [SANITIZED]

1. A build whose host segfaults, aborts, hangs and leaks at chosen points completes; the asset's
   infeasible points are exactly those points, each with the signal or the timeout as its
   message; every other point is feasible; the store holds each requested point once; the host
   ran twice at each affected point (the retry) and once everywhere else.
2. An isolated build of the well-behaved analytic host is byte-identical to the in-process one,
   also with --simulate-mapped (simulate requests carry a mesh to the worker).
3. Bad input is refused by name: a missing worker, a library that does not load,
   --sample-timeout <= 0, the isolation options without --isolate, a built-in host.
4. Ctrl-C while every worker hangs (no timeout) stops the build cleanly, at once.
SANITIZED=1 (an ASan build): the workers run with ASAN_OPTIONS=handle_segv=0, so a SIGSEGV
stays a signal, and the leak is left out (no address-space limit fits ASan's shadow memory).
Run with Debian's /usr/bin/python3 (sqlite3 and json only).
"""
import collections
import json
import os
import re
import signal
import sqlite3
import struct
import subprocess
import sys
import time

CLI, FAULTY, ANALYTIC, WORK = sys.argv[1:5]
SANITIZED = len(sys.argv) > 5 and sys.argv[5] == "1"
if SANITIZED:
    os.environ["ASAN_OPTIONS"] = "handle_segv=0:detect_leaks=0"
# The per-sample timeout: 200 times a plate sample's cost here (the hang points cost two each), more
# under ASan.
TIMEOUT = 4 if SANITIZED else 2
os.makedirs(WORK, exist_ok=True)
failures = []


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAIL:", what)


def run(args, env=None):
    p = subprocess.run([CLI] + args, capture_output=True, text=True, env=env, timeout=120)
    return p.returncode, p.stdout, p.stderr


def fresh(name):
    path = os.path.join(WORK, name)
    if os.path.exists(path):
        os.remove(path)
    return path


# The plate model (3 parameters) with 10 mm cells, and 8 samples: 71 points on a 5 x 5 grid of
# (length, width) levels, 2 to 5 points each, so every window below holds a few points. Windows
# are on length and width scaled to [0, 1] (faulty_host.c), away from the box's corners.
PLATE = ["-m", "plate", "--max-samples", "8"]
LOWER, UPPER = (40.0, 20.0), (100.0, 60.0)
WINDOWS = {"segv": (0.25, 0.5), "abort": (0.75, 0.5), "hang": (0.5, 0.25), "leak": (0.5, 0.75)}
if SANITIZED:
    del WINDOWS["leak"]
MESSAGES = {
    "segv": r"^host worker killed by signal 11 \(Segmentation fault\), on the first attempt and "
    r"on a retry in a fresh worker$",
    "abort": r"^host worker killed by signal 6 \(Aborted\), on the first attempt and on a retry",
    "hang": r"^host timed out after %d s \(worker killed\), on the first attempt and on a retry"
    % TIMEOUT,
    "leak": r"^host worker killed by signal 6 \(Aborted\), on the first attempt and on a retry",
}


def fault_of(x):
    t = tuple((x[i] - LOWER[i]) / (UPPER[i] - LOWER[i]) for i in range(2))
    for kind, w in WINDOWS.items():
        if t == w:
            return kind
    return None


def faults_build():
    store, log, asset = fresh("faults.db"), fresh("faults.log"), fresh("faults.cadi")
    windows = ",".join("%s=%g:%g:%g:%g" % (k, w[0], w[0], w[1], w[1]) for k, w in WINDOWS.items())
    rc, out, err = run(["build", "--host", FAULTY, "--host-options",
                        "edge=10," + windows + ",log=" + log] + PLATE +
                       ["--isolate", "--sample-timeout", str(TIMEOUT), "-j", "2", "--store", store, "-o",
                        asset, "-q"] + ([] if SANITIZED else ["--worker-memory", "64"]))
    print(out)
    check(rc == 0, "the faulty build exits 0 (got %d: %s)" % (rc, err[-2000:]))
    if rc != 0:
        return
    m = re.search(r"points requested (\d+), host evaluations (\d+)", out)
    iso = re.search(r"isolation +(\d+) workers \((\d+) started\), (\d+) requests, (\d+) answered, "
                    r"(\d+) retries, (\d+) infeasible after a retry; worker failures: (\d+) "
                    r"crashed, (\d+) timed out", out)
    check(m and iso, "the summary has the points and the isolation line")
    if not (m and iso):
        return
    requested, evaluations = int(m.group(1)), int(m.group(2))
    workers, started, requests, answered, retries, given_up, crashed, timed_out = map(
        int, iso.groups())

    db = sqlite3.connect(store)
    keys = [struct.unpack("<%dd" % (len(r[0]) // 8), r[0]) for r in db.execute("SELECT x FROM samples")]
    db.close()
    calls = collections.Counter()
    with open(log) as f:
        for line in f:
            calls[tuple(float(v) for v in line.split())] += 1
    rc, inspect, _ = run(["inspect", asset, "--json"])
    infeasible = {tuple(p["x"]): p["message"] for p in json.loads(inspect)["infeasible_points"]}

    affected = {x: fault_of(x) for x in keys if fault_of(x)}
    by_kind = collections.Counter(affected.values())
    print("points %d, affected %s, retries %d" % (len(keys), dict(by_kind), retries))
    for kind in WINDOWS:
        check(by_kind[kind] >= 1, "the %s window holds a requested point" % kind)
    check(len(set(keys)) == len(keys) == requested == evaluations == requests == answered,
          "each requested point is in the store once and answered once (store %d, requested %d, "
          "evaluations %d, requests %d, answered %d)" % (len(keys), requested, evaluations,
                                                         requests, answered))
    check(set(infeasible) == set(affected), "the asset's infeasible points are the affected ones")
    for x, kind in affected.items():
        check(re.search(MESSAGES[kind], infeasible.get(x, "")),
              "%s point %s: message %r" % (kind, x, infeasible.get(x)))
    check(set(calls) == set(keys), "the host ran at exactly the requested points")
    for x in keys:
        want = 2 if x in affected else 1
        check(calls[x] == want, "host calls at %s: %d, expected %d" % (x, calls[x], want))
    check(retries == given_up == len(affected), "one retry per affected point, each given up")
    check(timed_out == 2 * by_kind["hang"], "two timeouts per hang point")
    check(crashed == 2 * (by_kind["segv"] + by_kind["abort"] + by_kind.get("leak", 0)),
          "two crashes per segv, abort and leak point")
    check(workers == 2 and started == 2 + 2 * len(affected), "a fresh worker after every failure")


def identical_builds():
    for extra in ([], ["--simulate-mapped"]):
        name = "mapped" if extra else "plain"
        inproc, isolated = fresh(name + "_inprocess.cadi"), fresh(name + "_isolated.cadi")
        common = ["build", "--host", ANALYTIC, "--host-options", "edge=10"] + PLATE + extra + ["-q"]
        rc1, _, err1 = run(common + ["-o", inproc])
        rc2, out2, err2 = run(common + ["--isolate", "--sample-timeout", "30", "-o", isolated])
        check(rc1 == 0 and rc2 == 0, "%s builds succeed: %s %s" % (name, err1[-500:], err2[-500:]))
        if rc1 == 0 and rc2 == 0:
            with open(inproc, "rb") as a, open(isolated, "rb") as b:
                check(a.read() == b.read(), "%s: isolated asset is byte-identical" % name)
            check(re.search(r"0 retries, 0 infeasible after a retry", out2),
                  "%s: no retries on a well-behaved host" % name)


def bad_input():
    base = ["build", "--host", ANALYTIC, "--max-samples", "4", "-q", "--isolate",
            "-o", fresh("bad.cadi")]
    cases = [
        ("missing worker", base, dict(os.environ, CADINTERP_HOST_WORKER="/nonexistent/worker"),
         r"cannot run the host worker /nonexistent/worker"),
        ("library that does not load", ["build", "--host", "/nonexistent/libhost.so", "--isolate",
                                         "-o", fresh("bad.cadi")], None,
         r"cannot load host library /nonexistent/libhost.so"),
        ("zero timeout", base + ["--sample-timeout", "0"], None, r"--sample-timeout must be in"),
        ("negative timeout", base + ["--sample-timeout", "-1"], None,
         r"--sample-timeout must be in"),
        ("timeout without --isolate", ["build", "--host", ANALYTIC, "--sample-timeout", "1",
                                       "-o", fresh("bad.cadi")], None,
         r"--sample-timeout and --worker-memory need --isolate"),
        ("with --calling-thread", base + ["--calling-thread"], None,
         r"--isolate calls the host in worker processes, --calling-thread on this thread"),
        ("built-in host", ["build", "--host", "analytic", "--isolate", "-o", fresh("bad.cadi")],
         None, r"--isolate runs the host in worker processes, which load it from a library"),
    ]
    for name, args, env, pattern in cases:
        rc, _, err = run(args, env)
        check(rc != 0 and re.search(pattern, err), "%s: exit %d, stderr %r" % (name, rc, err))


def interrupt():
    args = [CLI, "build", "--host", FAULTY, "--host-options", "edge=10,hang=0:1"] + PLATE + [
        "--isolate", "--store", fresh("interrupt.db"), "-o", fresh("interrupt.cadi")]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1)
    p.send_signal(signal.SIGINT)
    start = time.monotonic()
    _, err = p.communicate(timeout=60)
    check(p.returncode == 1 and "CADINTERP_E_CANCELLED" in err and
          time.monotonic() - start < 5, "Ctrl-C with hung workers: exit %d in %.1f s, %r" %
          (p.returncode, time.monotonic() - start, err[-500:]))


faults_build()
identical_builds()
bad_input()
interrupt()
print("%d failure(s)" % len(failures))
sys.exit(1 if failures else 0)

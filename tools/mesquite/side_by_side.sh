#!/bin/bash
# Side-by-side timing: Mesquite FeasibleNewton (mq_driver) vs `meshsmooth smooth --method newton`,
# both on one core (taskset -c 0), runs interleaved, medians of REPS (default 3).
#
# usage: side_by_side.sh MESHSMOOTH_BIN MESH_DIR [MESH ...]
#   MESH ...   mesh names without .vtk (default: the 11 meshes of the README table)
#   env: REPS=3  CPU=0  MQ_DRIVER=<dir of this script>/mq_driver  KEEP=1 (keep the temp dir)
#        THREADS="1"  meshsmooth's thread counts: 1 runs on core $CPU beside Mesquite;
#                     T > 1 on cores 0..T-1 (Mesquite has no threads: it always runs on $CPU)
#
# The stopping point of both: the first iterate whose F is within 1e-4 (relative) of Mesquite's
# final F (Mesquite's run to |grad F| < 1e-6 or 100 iterations, once per mesh).
# Mesquite time: its optimisation call (InstructionQueue::run_instructions, setup included) in a
# run capped (mq_driver -n K) at the first iteration K that reaches that F; K is found by
# bisection over capped probe runs (F decreases from iteration to iteration).
# meshsmooth time: first history row whose objective reaches that F, plus the summary line's
# "setup X s" (history seconds leave setup out).
# "MQ FN iters (to F)": Mesquite's iterations to converge, in brackets K.
# "ms newton iters (to MQ F)": meshsmooth's own iteration count to |grad F| < 1e-6 (summary line),
# in brackets the history row at which it first reached Mesquite's F within 1e-4.
# Prints a Markdown table on stdout; progress goes to stderr.
set -euo pipefail

if [ $# -lt 2 ]; then
  sed -n 2,14p "$0" >&2
  exit 2
fi
MS_BIN=$(readlink -f "$1"); MESH_DIR=$(readlink -f "$2"); shift 2
HERE=$(cd "$(dirname "$0")" && pwd)
MQ=${MQ_DRIVER:-$HERE/mq_driver}
REPS=${REPS:-3}
CPU=${CPU:-0}
THREADS=${THREADS:-1}
if [ $# -gt 0 ]; then MESHES=("$@"); else
  MESHES=(tire cube-clip-5 flat-tet-sphere perturbed_box_tet_20 cub_wedge_like shashkov tri_20258
          shashkov_quad overt_hyb_1 1000hex-block-internal-bias cub_fru)
fi
[ -x "$MS_BIN" ] || { echo "not executable: $MS_BIN" >&2; exit 1; }
[ -x "$MQ" ] || { echo "Mesquite driver missing: $MQ (run $HERE/build_driver.sh)" >&2; exit 1; }

TMP=$(mktemp -d /tmp/side_by_side.XXXXXX)
[ "${KEEP:-0}" = 1 ] || trap 'rm -rf "$TMP"' EXIT
RES="$TMP/results.txt"   # one record per run: MQ|MS <mesh> <rep> <fields...>
: > "$RES"

for m in "${MESHES[@]}"; do
  f="$MESH_DIR/$m.vtk"
  [ -f "$f" ] || { echo "missing $f" >&2; exit 1; }
  # Mesquite's own convergence, then the first iteration that reaches its F within 1e-4
  # (mq_driver's stdout, last line: "iterations seconds F_all")
  mq_run() {
    taskset -c "$CPU" "$MQ" "$f" "$@" 2>"$TMP/mq_stderr" | tail -n 1 ||
      { echo "mq_driver failed on $f:" >&2; cat "$TMP/mq_stderr" >&2; exit 1; }
  }
  read -r full_it _ full_F <<< "$(mq_run)"
  lo=1; hi=$full_it
  while [ "$lo" -lt "$hi" ]; do
    mid=$(((lo + hi) / 2))
    read -r _ _ F_mid <<< "$(mq_run -n "$mid")"
    if python3 -c "import sys; sys.exit(0 if $F_mid <= $full_F * (1 + 1e-4) else 1)"; then hi=$mid; else lo=$((mid + 1)); fi
  done
  echo "MQFULL $m 0 $full_it $full_F $lo" >> "$RES"
  echo "[$m] mesquite converges in $full_it iterations to F $full_F; reaches it within 1e-4 at iteration $lo" >&2
  for r in $(seq 1 "$REPS"); do
    line=$(mq_run -n "$lo")
    echo "MQ $m $r $line" >> "$RES"
    echo "[$m #$r] mesquite: $line" >&2
    # meshsmooth, at each thread count
    for t in $THREADS; do
      if [ "$t" = 1 ]; then cpus=$CPU; else cpus=0-$((t - 1)); fi
      h="$TMP/h_${m}_${r}_$t.csv"
      s=$(RAYON_NUM_THREADS=$t taskset -c "$cpus" "$MS_BIN" smooth "$f" -o "$TMP/x.vtk" \
            --method newton --device cpu --history "$h" -q 2>"$TMP/ms_stderr") ||
        { echo "meshsmooth failed on $f:" >&2; cat "$TMP/ms_stderr" >&2; exit 1; }
      echo "MS$t $m $r $h $s" >> "$RES"
      echo "[$m #$r] meshsmooth ($t threads): $s" >&2
    done
  done
done

python3 - "$RES" "$MESH_DIR" $THREADS <<'PY'
import re, sys, statistics, csv, os
res, mesh_dir, threads = sys.argv[1], sys.argv[2], sys.argv[3:]
mq, ms, order, full = {}, {}, [], {}
for line in open(res):
    p = line.split(None, 3)
    kind, mesh = p[0], p[1]
    if mesh not in order: order.append(mesh)
    if kind == "MQFULL":
        it, F, k = p[3].split()
        full[mesh] = (int(it), float(F), int(k))
    elif kind == "MQ":
        it, sec, F = p[3].split()
        mq.setdefault(mesh, []).append((int(it), float(sec), float(F)))
    else:
        hist, summary = p[3].split(None, 1)
        ms.setdefault((mesh, kind[2:]), []).append((hist, summary.strip()))

NAMES = {3: "edge", 5: "tri", 9: "quad", 10: "tet", 12: "hex", 13: "wedge", 14: "pyramid"}
def cells(path):
    """element count and type label from the legacy VTK CELL_TYPES section"""
    toks = open(path).read().split()
    i = toks.index("CELL_TYPES"); n = int(toks[i + 1])
    types = [int(t) for t in toks[i + 2:i + 2 + n]]
    counts = {}
    for t in types: counts[t] = counts.get(t, 0) + 1
    label = "+".join(NAMES.get(t, str(t)) for t, _ in sorted(counts.items(), key=lambda kv: -kv[1]))
    return n, label, all(t in (5, 9) for t in types)

def fmt_s(x): return "%.3f" % x
summ_re = re.compile(r"after (\d+) iterations in ([0-9.eE+-]+) s \(setup ([0-9.eE+-]+) s\); "
                     r"F ([0-9.eE+-]+) -> ([0-9.eE+-]+)")
head = "| mesh | elements | MQ FN iters (to F) / s to F / F | ms newton iters (to MQ F) |"
for t in threads:
    head += " ms s to MQ F (+setup), %s thread%s | ratio |" % (t, "" if t == "1" else "s")
print(head)
print("|" + "---|" * (4 + 2 * len(threads)))
notes = []
for mesh in order:
    n, label, planar = cells(os.path.join(mesh_dir, mesh + ".vtk"))
    runs = mq[mesh]
    it_mq, F_mq, k_mq = full[mesh]
    target = F_mq * (1 + 1e-4)
    Fs = [r[2] for r in runs]
    if any(F > target for F in Fs) or len(set(r[0] for r in runs)) > 1:
        notes.append("%s: capped Mesquite runs differ or miss its F (iters %s, F %s)" % (mesh, [r[0] for r in runs], Fs))
    t_mq = statistics.median(r[1] for r in runs)
    it_str = ("%d (cap)" % it_mq if it_mq >= 100 else str(it_mq)) + " (%d)" % k_mq
    name = mesh + (" (2D)" if planar else "")
    elems = "{:,} {}".format(n, label)
    mq_col = "%s / %s / %.6f" % (it_str, fmt_s(t_mq), F_mq)
    cells_t, it_ms, it_tot = [], [], []
    for t in threads:
        t_ms, missed = [], 0
        for hist, summary in ms[(mesh, t)]:
            mt = summ_re.search(summary)
            if not mt:
                notes.append("%s: cannot parse meshsmooth summary: %s" % (mesh, summary)); continue
            setup = float(mt.group(3)); it_tot.append(int(mt.group(1)))
            hit = None
            with open(hist) as fh:
                for row in csv.DictReader(fh):
                    if float(row["objective"]) <= target:
                        hit = (int(row["iteration"]), float(row["seconds"])); break
            if hit is None:
                missed += 1
                notes.append("%s (%s threads): meshsmooth stopped at F %s after %s iterations without reaching "
                             "Mesquite's F %.6f within 1e-4" % (mesh, t, mt.group(5), mt.group(1), F_mq))
                continue
            it_ms.append(hit[0]); t_ms.append(hit[1] + setup)
        if t_ms:
            tm = statistics.median(t_ms)
            r = t_mq / tm
            cells_t.append(" %s | %.2f%s |" % (fmt_s(tm), r, "" if r >= 1 else " (slower)"))
        else:
            cells_t.append(" not reached | — |")
        if missed and t_ms:
            notes.append("%s (%s threads): median over %d of %d meshsmooth runs" % (mesh, t, len(t_ms), len(ms[(mesh, t)])))
    j = lambda xs: "/".join(map(str, sorted(set(xs))))
    ms_it = "%s (%s)" % (j(it_tot), j(it_ms)) if it_ms else "—"
    print("| %s | %s | %s | %s |%s" % (name, elems, mq_col, ms_it, "".join(cells_t)))
for s in notes: print("\nNote: " + s)
PY

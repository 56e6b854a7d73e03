# Paired table of a loop-closure study (scripts/loop_closure_study.sh): mean over seeds of each
# summary metric with loop_closure false and true, the mean paired difference and its standard
# error, and how many runs got worse.
import collections, glob, json, math, os, sys
root=sys.argv[1]
d=collections.defaultdict(dict)
for f in glob.glob(f"{root}/*.json"):
    c, lc, s = os.path.basename(f)[:-5].split('_')
    d[(c,lc)][int(s)] = json.load(open(f))
def ms(x):
    n=len(x); m=sum(x)/n
    sd=math.sqrt(sum((v-m)**2 for v in x)/(n-1)) if n>1 else float('nan')
    return m, sd/math.sqrt(n)
print("| condition | seeds | pose RMSE (m) false → true | Δ ± se | final keyframe RMSE (m) false → true | Δ ± se | final ET-GOPSA false → true | Δ ± se | runs worse (pose / kf / ET) | loops/run |")
print("|---|---|---|---|---|---|---|---|---|---|")
LABELS = {"r0a1": "ΔR 0, Δθ 1°", "r01a1": "ΔR 0.1 m, Δθ 1°", "r0a5": "ΔR 0, Δθ 5°",
          "r01a5": "ΔR 0.1 m, Δθ 5°", "5g": "5G spectral"}
for c in LABELS:
    a=d.get((c,"false"),{}); b=d.get((c,"true"),{})
    ss=sorted(set(a)&set(b))
    if not ss: continue
    row=[LABELS[c], str(len(ss))]
    worse=[]
    for key in ["pose_rmse_m","keyframe_rmse_m","etgospa"]:
        x=[a[s][key] for s in ss]; y=[b[s][key] for s in ss]
        diff=[q-p for p,q in zip(x,y)]
        m,se=ms(diff)
        fmt = "{:.1f}" if key=="etgospa" else "{:.3f}"
        row.append(fmt.format(ms(x)[0])+" → "+fmt.format(ms(y)[0]))
        row.append(("{:+.1f} ± {:.1f}" if key=="etgospa" else "{:+.3f} ± {:.3f}").format(m,se))
        worse.append(str(sum(v>1e-9 for v in diff)))
    row.append(" / ".join(worse))
    row.append("{:.2f}".format(sum(b[s]["loop_closures"] for s in ss)/len(ss)))
    print("| "+" | ".join(row)+" |")

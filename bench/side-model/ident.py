"""Issue 33, part 4: commissioning identifications tried on the side model (sim.py), with
the 1 kHz SYNC sampling, +-20 us latch jitter, 2^20-count feedback, torque noise.

Run: python3 bench/side-model/ident.py
 - drive delay: (A) lag at constant speed +-v, (B) chirp, phase slope of target->feedback
   after the servo model's phase, fitted 1-20 Hz; three hidden plants.
 - backlash: slow reversal against a table probe, the windup taken out with the drive's
   torque (levels and elastic slope).
 - spindle encoder error (1x, 2x, 3x) vs a true once-per-turn speed variation: fits at
   three speeds, the true variation scaling as 1/Omega^2 (a once-per-turn torque).
"""
import math
import random
import sys
import numpy as np

sys.path.insert(0, __import__("os").path.dirname(__import__("os").path.abspath(__file__)))
import params as P
import sim
import loop

TAU = 2 * math.pi
ARCSEC = math.pi / 180 / 3600

PLANTS = [  # hidden values: total drive delay (s), backlash (arcsec) -- none the shipped ones
    dict(name="plant A", delay=0.86e-3, backlash=6.0),
    dict(name="plant B", delay=1.13e-3, backlash=25.0),
    dict(name="plant C", delay=1.25e-3, backlash=50.0),
]
VEL, POS = 74, 16          # the stable tuning of loop.py on the derived plant


def delay_ramp(p, hidden, v_deg_s=10.0, seed=1):
    """(A) Constant speed +v then -v; lag = (target - feedback)/v in the steady windows."""
    w = math.radians(v_deg_s)

    def prof(t):  # 0.5 s accelerate, 1.5 s const, 0.5 s reverse..., -v 1.5 s
        a = w / 0.3
        if t < 0.3:
            return 0.5 * a * t * t
        if t < 2.0:
            return 0.5 * a * 0.09 + w * (t - 0.3)
        x0 = 0.5 * a * 0.09 + w * 1.7
        if t < 2.6:
            tt = t - 2.0
            return x0 + w * tt - a * tt * tt / 2
        x1 = x0 + w * 0.6 - a * 0.36 / 2
        return x1 - w * (t - 2.6)
    o = sim.run(p, VEL, POS, 4.2, prof, delay_s=hidden["delay"], backlash_arcsec=hidden["backlash"],
                torque_noise_nm=0.02, seed=seed)
    t = np.array(o["t"])
    lag = (np.array(o["target"]) - np.array(o["fb"])) / p["i"]   # table rad
    fwd = (t > 1.0) & (t < 2.0)
    bwd = (t > 3.3) & (t < 4.2)
    # lag = v tau + offset;  the offset (play side, windup) cancels in the difference
    tau = (lag[fwd].mean() - lag[bwd].mean()) / (2 * w)
    return tau


def delay_chirp(p, hidden, amp_deg=0.03, f0=1.0, f1=20.0, secs=12.0, seed=2, model=None):
    """(B) A linear chirp of amp_deg of the table; H = target -> latched feedback; the
    phase of H over the servo model's closed loop, fitted as -w tau (weighted)."""
    amp = math.radians(amp_deg)
    k = (f1 - f0) / secs

    def ch(t):
        return amp * math.sin(TAU * (f0 * t + 0.5 * k * t * t)) if t < secs else 0.0
    # a slow drift keeps the play on one flank (as the bearing friction in a cut would)
    drift = math.radians(2.0)

    def prof(t):
        return drift * t + ch(t)
    o = sim.run(p, VEL, POS, secs, prof, delay_s=hidden["delay"], backlash_arcsec=hidden["backlash"],
                torque_noise_nm=0.02, seed=seed)
    tt = np.array(o["t"])
    r = np.array(o["target"]) / p["i"] - drift * tt
    y = np.array(o["fb"]) / p["i"] - drift * tt
    r -= r.mean()
    y -= y.mean()
    R = np.fft.rfft(r * np.hanning(len(r)))
    Y = np.fft.rfft(y * np.hanning(len(y)))
    f = np.fft.rfftfreq(len(r), 1e-3)
    sel = (f > f0 + 0.5) & (f < f1 - 0.5)
    H = Y[sel] / R[sel]
    w = TAU * f[sel]
    m = model if model is not None else p
    _, Tcl, _ = loop.error_frf(m, w, VEL, POS)
    ph = np.unwrap(np.angle(H / Tcl))
    wt = np.abs(R[sel]) ** 2
    tau = -np.sum(wt * w * ph) / np.sum(wt * w * w)   # LS through the origin
    tau_raw = -np.sum(wt * w * np.unwrap(np.angle(H))) / np.sum(wt * w * w)
    return tau, tau_raw


def backlash_reversal(p, hidden, v_deg_s=0.05, seed=3, probe_noise_arcsec=0.15):
    """Slow move +, reverse; probe on the table. Lost motion from the probe (motor travel
    while the table stands), the windup 2 T_f / k out of it from the motor torque."""
    w = math.radians(v_deg_s)
    tr = 1.5

    def prof(t):
        return w * t if t < tr else w * tr - w * (t - tr)
    o = sim.run(p, VEL, POS, 3.2, prof, delay_s=hidden["delay"], backlash_arcsec=hidden["backlash"],
                torque_noise_nm=0.0, seed=seed)
    rng = np.random.default_rng(seed)
    i = p["i"]
    t = np.array(o["t"])
    mot = np.array(o["fb"]) / i / ARCSEC                     # motor, table arcsec
    probe = np.array(o["table"]) / ARCSEC + rng.normal(0, probe_noise_arcsec, len(t))
    tq = np.array(o["torque"]) + rng.normal(0, 0.01, len(t))  # drive's torque actual, 0.01 Nm noise
    # forward steady window, backward steady window (after the table moves again)
    fwd = (t > 1.0) & (t < 1.45)
    gap = (mot - probe)
    bwd = t > 2.8
    lost = gap[fwd].mean() - gap[bwd].mean()                   # motor-table offset change
    # torque levels: forward, backward (table moving), and inside the play (motor only)
    t_f, t_b = tq[fwd].mean(), tq[bwd].mean()
    # inside the play: after reversal the torque is flat at -motor friction; find the
    # elastic ramps as the parts where the table stands and the torque moves
    rev = (t > tr) & (t < 2.8)
    mr, tqr, pr = mot[rev], tq[rev], probe[rev]
    stand = np.abs(pr - probe[fwd][-50:].mean()) < 0.6
    plateau_t = tq[(t > tr + 0.05) & (t < 2.8) & (np.abs(probe - probe[fwd][-50:].mean()) < 0.6)]
    fric_m = np.median(np.abs(plateau_t)) if len(plateau_t) else 0.0
    tf_table = max(0.0, ((t_f - t_b) / 2 - fric_m) * i)     # mesh-winding friction at the table
    outs = []
    for k_known in (p["k"], 0.5 * p["k"], 1.5 * p["k"]):
        outs.append(lost - 2 * tf_table / k_known / ARCSEC)
    return lost, outs, fric_m, tf_table
    # elastic slope dT/dtheta (motor Nm per table arcsec) where the torque is between the
    # levels and not at the play plateau
    lo, hi = min(t_f, t_b), max(t_f, t_b)
    span = hi - lo
    plateau = np.median(tqr[stand & (np.abs(tqr - tqr[stand].min()) > -1)])
    ramp = stand & (np.abs(tqr - plateau) > 0.15 * span) & (tqr < hi - 0.1 * span) & (tqr > lo + 0.1 * span)
    if ramp.sum() > 5:
        slope = abs(np.polyfit(mr[ramp], tqr[ramp], 1)[0])    # Nm (motor) per arcsec (table)
        k_est = slope * i / ARCSEC                             # Nm/rad at the table
    else:
        k_est = float("nan")
    tf_table = (t_f - t_b) / 2 * i                             # friction incl. motor's, at table
    windup = (t_f - t_b) / slope if ramp.sum() > 5 else float("nan")  # 2 T / k, arcsec
    return lost, lost - windup, k_est, tf_table


def spindle_encoder(seed=4, a=(26.0, 6.0, 3.0), true_b=12.0, speeds=(60.0, 120.0, 200.0),
                    secs=10.0, ref_rpm=120.0):
    """Encoder error a_k (arcsec, harmonics 1..3) and a true once-per-turn angle variation
    b (arcsec at ref_rpm, scaling 1/Omega^2): identified from readings at three speeds."""
    rng = np.random.default_rng(seed)
    ph_a = rng.uniform(0, TAU, len(a))
    ph_b = rng.uniform(0, TAU)
    counts = 10000
    fits = []
    for rpm in speeds:
        W = rpm / 60 * TAU
        n = int(secs * 1000)
        t = np.arange(n) * 1e-3 + rng.uniform(-20e-6, 20e-6, n)
        # true angle: constant speed, slow slip drift, 0.3 % ripple at the gash frequency,
        # the true once-per-turn variation
        fg = rpm * 10 / 60
        th = W * t + 0.002 * np.sin(0.3 * t) + 0.003 * W / (TAU * fg) * np.sin(TAU * fg * t)
        th += true_b * ARCSEC * (ref_rpm / rpm) ** 2 * np.sin(th + ph_b)
        read = th + sum(ak * ARCSEC * np.sin((k + 1) * th + ph_a[k]) for k, ak in enumerate(a))
        read = np.floor(read / TAU * counts) / counts * TAU
        # fit: smooth polynomial in t (speed, slip) + harmonics of the reading's angle
        tn = (t - t.mean()) / t.std()
        cols = [tn**d for d in range(6)]
        for k in range(1, 4):
            cols += [np.sin(k * read), np.cos(k * read)]
        A = np.stack(cols, 1)
        coef, *_ = np.linalg.lstsq(A, read, rcond=None)
        c = [complex(coef[6 + 2 * (k - 1) + 1], coef[6 + 2 * (k - 1)]) / ARCSEC for k in range(1, 4)]
        fits.append(c)
    # harmonic 1: c1(Omega) = a1 + b1 (ref/Omega)^2  (complex), least squares over speeds
    x = np.array([(ref_rpm / s) ** 2 for s in speeds])
    c1 = np.array([f[0] for f in fits])
    M = np.stack([np.ones_like(x), x], 1).astype(complex)
    (a1, b1), *_ = np.linalg.lstsq(M, c1, rcond=None)
    a23 = [np.mean([f[k] for f in fits]) for k in (1, 2)]
    # what a single-speed fit (today's identifier) would call encoder error at 120 rpm
    single = abs(fits[1][0])
    return dict(a1=abs(a1), b1=abs(b1), a2=abs(a23[0]), a3=abs(a23[1]), single=single,
                truth=(a, true_b))


if __name__ == "__main__":
    der = P.derived()
    print(f"tuning {VEL}/{POS} Hz on the derived plant (params.derived); latch jitter +-20 us, "
          f"torque noise 0.02 Nm rms per loop sample")
    print("\nDRIVE DELAY (hidden total delay; estimates in us)")
    for h in PLANTS:
        ta = [delay_ramp(der, h, seed=s) for s in (1, 2)] + [delay_ramp(der, h, v_deg_s=1.0, seed=3)]
        tb = [delay_chirp(der, h, seed=s) for s in (1,)] + [delay_chirp(der, h, f0=0.5, f1=5.0, seed=2)]
        # model mismatch: the chirp fitted with the shipped-number model instead of the plant's
        tb_mis = delay_chirp(der, h, seed=5, model=P.shipped())
        print(f"  {h['name']}: true {h['delay']*1e6:.0f}; ramp +-10 deg/s: "
              + ", ".join(f"{x*1e6:.1f}" for x in ta)
              + "; chirp 0.03 deg 1-20 Hz, 0.5-5 Hz: " + ", ".join(f"{x[0]*1e6:.1f} (raw {x[1]*1e6:.1f})" for x in tb)
              + f"; chirp with a wrong plant model: {tb_mis[0]*1e6:.1f}")
    print("\nBACKLASH by reversal at 0.05 deg/s with a table probe (0.15 arcsec noise)")
    for h in PLANTS:
        lost, bls, fm, tf = backlash_reversal(der, h)
        print(f"  {h['name']}: true {h['backlash']:.1f} arcsec; lost motion {lost:.2f} "
              f"({(lost/h['backlash']-1)*100:+.1f} %); minus windup 2 T_f/k: {bls[0]:.2f} "
              f"({(bls[0]/h['backlash']-1)*100:+.1f} %), with k off by -50/+50 %: {bls[1]:.2f} / {bls[2]:.2f}; "
              f"motor friction {fm:.3f} Nm, table friction winding the mesh {tf:.2f} Nm")
    print("\nSPINDLE ENCODER: error harmonics vs a true once-per-turn variation (1/Omega^2)")
    for seed, a, b in ((4, (26.0, 6.0, 3.0), 12.0), (5, (15.0, 4.0, 2.0), 20.0), (6, (40.0, 8.0, 0.0), 0.0)):
        r = spindle_encoder(seed=seed, a=a, true_b=b)
        print(f"  truth a = {a} arcsec, true variation {b} arcsec at 120 rpm: "
              f"a1 {r['a1']:.2f} ({(r['a1']/a[0]-1)*100:+.1f} %), a2 {r['a2']:.2f}, a3 {r['a3']:.2f}, "
              f"b1 {r['b1']:.2f}; a single-speed fit at 120 rpm says {r['single']:.2f}")

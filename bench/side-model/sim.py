"""Issue 33: nonlinear side model of the B axis: servo.rs's drive (200 us loop, 2^20
feedback, 1500 Hz speed filter, PI with anti-windup, torque limit, CSP targets at 1 kHz
applied after a (hidden) delay with linear interpolation/extrapolation), the motor (+worm)
coupled two ways through the mesh (stiffness, damping, backlash) to the table (bearing
friction, load). Physics: semi-implicit Euler at 100 us like bench/plant.

Run: python3 bench/side-model/sim.py      (part 2a: shipped tuning, stability)
"""
import math
import random
import sys

sys.path.insert(0, __import__("os").path.dirname(__import__("os").path.abspath(__file__)))
import params as P

TAU = 2 * math.pi
ARCSEC = math.pi / 180 / 3600


def run(p, vel_hz, pos_hz, seconds, target_fn, delay_s=1e-3, backlash_arcsec=None,
        two_way=True, dt=1e-4, jitter_s=20e-6, torque_noise_nm=0.0, seed=1,
        tuned_j=None, kick_nm=0.0, table_load_fn=None, record=True, probe=False):
    """target_fn(t) -> table angle target (rad of the table) at SYNC instants (1 kHz).
    Returns per-SYNC records: t, target (motor rad), latched feedback (motor rad, 2^20
    counts), true motor rad, true table rad, motor torque."""
    rng = random.Random(seed)
    i = p["i"]
    jm = p["j_motor"]
    jt = p["j_table"]
    k, c = p["k"], p["c"]
    if not two_way:
        jm = jm + jt / i**2
    h = (p["backlash_arcsec"] if backlash_arcsec is None else backlash_arcsec) * ARCSEC / 2
    j_tuned = tuned_j if tuned_j is not None else p["j_motor"] + jt / i**2
    wv = TAU * vel_hz
    kp, ki, kv = j_tuned * wv, j_tuned * wv * wv / 4, TAU * pos_hz
    T = p["loop_s"]
    cpr = p["fb_counts"] / TAU
    a_f = 1 - math.exp(-TAU * p["filt_hz"] * T)
    period = p["period_s"]
    nsteps = int(round(seconds / dt))
    loop_every = int(round(T / dt))
    sync_every = int(round(period / dt))
    # state
    th_m = target_fn(0.0) * i
    w_m = 0.0
    th_t = th_m / i - (h if h > 0 else 0.0)
    w_t = 0.0
    integ = 0.0
    v_est = 0.0
    fb_prev = math.floor(th_m * cpr) / cpr
    torque = 0.0
    targets = [(-period, th_m), (0.0, th_m)]  # (time sent, motor rad)
    out = dict(t=[], target=[], fb=[], motor=[], table=[], torque=[], sat=0, w_m=[])
    for n in range(nsteps):
        t = n * dt
        if n % sync_every == 0:
            # SYNC: the controller's new target, and the drive's latched feedback
            tgt = target_fn(t) * i
            targets.append((t, tgt))
            if len(targets) > 4000:
                targets = targets[-2000:]
            if record:
                lat = th_m + w_m * rng.uniform(-jitter_s, jitter_s)
                out["t"].append(t)
                out["target"].append(tgt)
                out["fb"].append(math.floor(lat * cpr) / cpr)
                out["motor"].append(th_m)
                out["table"].append(th_t)
                out["torque"].append(torque)
                out["w_m"].append(w_m)
        if n % loop_every == 0:
            # reference: the targets placed at (sent + delay), linear inter/extrapolation
            tr = t - delay_s
            # find the last two targets with time <= tr (or the first two)
            j = len(targets) - 1
            while j > 1 and targets[j][0] > tr:
                j -= 1
            (t0, r0), (t1, r1) = targets[j - 1], targets[j]
            if t1 > tr:          # extrapolate backwards is not needed; hold
                ref, ff = r1 if t1 <= tr else r0 + (r1 - r0) * max(0.0, (tr - t0)) / period, (r1 - r0) / period
            else:
                # latest segment ending at t1: slope from (t0, r0) to (t1, r1), extrapolated
                ff = (r1 - r0) / period
                ref = r1 + ff * (tr - t1)
                # if a newer target exists after t1, interpolate towards it
                if j + 1 < len(targets):
                    t2, r2 = targets[j + 1]
                    ff = (r2 - r1) / period
                    ref = r1 + ff * (tr - t1)
            fb = math.floor(th_m * cpr) / cpr
            raw = (fb - fb_prev) / T
            fb_prev = fb
            v_est += (raw - v_est) * a_f
            e = kv * (ref - fb) + p["ff"] * ff - v_est
            un = kp * e + integ
            torque = max(-p["peak_nm"], min(p["peak_nm"], un))
            if torque == un:
                integ += ki * e * T
            else:
                out["sat"] += 1
            if torque_noise_nm:
                torque += rng.gauss(0.0, torque_noise_nm)
        # mesh torque from the states at the start of the step
        d = th_m / i - th_t
        if d > h:
            tm = k * (d - h) + c * (w_m / i - w_t)
        elif d < -h:
            tm = k * (d + h) + c * (w_m / i - w_t)
        else:
            tm = 0.0
        load_t = p["bearing_nm"] * math.tanh(w_t / 0.01)
        if table_load_fn:
            load_t += table_load_fn(t)
        fric = p["friction_motor_nm"] * math.tanh(w_m / 0.01)
        kick = kick_nm if n * dt < 0.002 else 0.0
        if two_way:
            w_m += (torque + kick - fric - tm / i) / jm * dt
            w_t += (tm - load_t) / jt * dt
        else:
            # today's plant: the motor sees the table rigidly, the table hangs on the mesh
            w_m += (torque + kick - fric - load_t / i) / jm * dt
            w_t += (tm - load_t) / jt * dt
        th_m += w_m * dt
        th_t += w_t * dt
    return out


def summarize(out, i, last_s=0.3, dt_rec=1e-3):
    n = int(last_s / dt_rec)
    tq = out["torque"][-n:]
    tab = out["table"][-n:]
    mot = out["motor"][-n:]
    tgt = out["target"][-n:]
    err_m = [(a - b) / i / ARCSEC for a, b in zip(tgt, mot)]
    rel = [(m / i - t) / ARCSEC for m, t in zip(mot, tab)]
    return dict(torque_pp=max(tq) - min(tq), err_pp=max(err_m) - min(err_m),
                err_mean=sum(err_m) / n, rel_pp=max(rel) - min(rel))


if __name__ == "__main__":
    ship = P.shipped()
    der = P.derived()
    i = ship["i"]
    w_table = 7.02 / 60 * TAU  # thesis example table speed, rad/s

    def hold(t):
        return 0.0

    def ramp(t):
        # 1 s engagement to 7.02 rpm (s-curve free: constant acceleration), then constant
        if t < 1.0:
            return 0.5 * w_table * t * t
        return 0.5 * w_table + w_table * (t - 1.0)

    print("2a: nonlinear side model, limit cycles (last 0.3 s of 2.0 s)")
    print("plant | tuning v/p Hz | backlash | case | torque p-p Nm | sat. samples | motor err p-p arcsec | mesh windup p-p arcsec")
    for pname, p in (("shipped", ship), ("derived", der)):
        for (vel, pos) in ((400, 60), (100, 15), (50, 20) if pname == "shipped" else (74, 16)):
            for bl in (0.0, 10.0, 40.0):
                for case, fn in (("hold+kick", hold), ("7 rpm", ramp)):
                    for two in ((True,) if not (pname == "shipped" and vel == 400 and bl == 10.0) else (False, True)):
                        o = run(p, vel, pos, 2.0, fn, backlash_arcsec=bl, two_way=two,
                                kick_nm=0.5 if case == "hold+kick" else 0.0)
                        s = summarize(o, i)
                        print(f"{pname}{'' if two else ' ONE-WAY'} | {vel}/{pos} | {bl:.0f} | {case} | "
                              f"{s['torque_pp']:.2f} | {o['sat']} | {s['err_pp']:.2f} | {s['rel_pp']:.2f}")

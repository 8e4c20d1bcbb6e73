"""Issue 33: the B drive's loops (as bench/plant/src/servo.rs) on the linear two-mass
worm drive: open-loop Bode of the velocity loop and of the whole cascade (broken at the
torque), gain and phase margins, the stable tunings, following error at hobbing speeds.

Run: python3 bench/side-model/loop.py [--plot]
servo.rs, per loop sample (T = drives.loop_us = 200 us): feedback quantised; speed =
backward difference / T, first-order low-pass (1500 Hz, discretised exp); position P
(kv = 2 pi f_p) with velocity feed-forward; PI velocity kp = J w_v, ki = J w_v^2 / 4 with J
the drive's tuned (rigid) inertia; torque held over the sample (ZOH), no extra compute
delay. Here optionally a 2nd-order low-pass on the torque reference.
"""
import math
import sys
import numpy as np
from scipy import signal

sys.path.insert(0, __import__("os").path.dirname(__import__("os").path.abspath(__file__)))
import params as P

TAU = 2 * math.pi
ARCSEC = math.pi / 180 / 3600


def plant_ss(p, two_way=True):
    """Continuous plant torque at motor -> motor angle (motor coordinates)."""
    i = p["i"]
    j1 = p["j_motor"]
    j2 = p["j_table"] / i**2
    k2 = p["k"] / i**2
    c2 = p["c"] / i**2
    if not two_way:
        # one-way: the motor sees motor + table rigidly
        num, den = [1.0], [j1 + j2, 0.0, 0.0]
    else:
        num = [j2, c2, k2]
        den = np.polymul([1, 0, 0], [j1 * j2, c2 * (j1 + j2), k2 * (j1 + j2)])
    return num, den


def discrete_plant(p, T, two_way=True):
    num, den = plant_ss(p, two_way)
    nd, dd, _ = signal.cont2discrete((num, den), T, method="zoh")
    return np.squeeze(nd), dd


def freqz(num, den, w, T):
    z = np.exp(1j * w * T)
    return np.polyval(num, z) / np.polyval(den, z)  # num/den in descending powers of z


def loop_frf(p, w, vel_hz, pos_hz, lpf_hz=None, notch=None, two_way=True, tuned_j=None):
    """Frequency responses (arrays at w rad/s): velocity open loop L_v, cascade open loop
    L (broken at the torque), plant G (torque -> motor angle), controller parts."""
    T = p["loop_s"]
    z = np.exp(1j * w * T)
    zi = 1 / z
    jt = tuned_j if tuned_j is not None else p["j_motor"] + p["j_table"] / p["i"] ** 2
    wv = TAU * vel_hz
    kp, ki = jt * wv, jt * wv * wv / 4
    kv = TAU * pos_hz
    nd, dd = discrete_plant(p, T, two_way)
    G = freqz(nd, dd, w, T)
    a = 1 - math.exp(-TAU * p["filt_hz"] * T)
    F = a / (1 - (1 - a) * zi)          # speed low-pass
    D = (1 - zi) / T                    # backward difference
    C = kp + ki * T * zi / (1 - zi)     # PI, integral of past errors
    Fl = np.ones_like(z)
    if lpf_hz:
        # 2nd-order low-pass (zeta 0.7), Tustin
        wl = TAU * lpf_hz
        b, a2 = signal.bilinear([wl * wl], [1, 2 * 0.7 * wl, wl * wl], fs=1 / T)
        Fl = np.polyval(b, z) / np.polyval(a2, z)
    if notch:
        fn, depth, width = notch
        wn = TAU * fn
        b, a2 = signal.bilinear([1, 2 * depth * width * wn, wn * wn], [1, 2 * width * wn, wn * wn], fs=1 / T)
        Fl = Fl * np.polyval(b, z) / np.polyval(a2, z)
    Lv = C * Fl * F * D * G
    L = C * Fl * (F * D + kv) * G
    return dict(G=G, Lv=Lv, L=L, C=C, F=F, D=D, Fl=Fl, kp=kp, ki=ki, kv=kv)


def margins(L, w):
    """Gain margin (dB) at every -180 crossing and phase margin (deg) at every 0 dB
    crossing; the worst of each. Unstable (encirclements) shows as negative margins."""
    mag = np.abs(L)
    ph = np.unwrap(np.angle(L))
    gm, pm = [], []
    for k in range(len(w) - 1):
        if (mag[k] - 1) * (mag[k + 1] - 1) < 0:
            pm.append((math.degrees(ph[k]) % 360 - 180 + 360) % 360 - 180 + 0.0)
        # phase crossing of -180 (mod 360)
        a0 = (math.degrees(ph[k]) + 180) % 360
        a1 = (math.degrees(ph[k + 1]) + 180) % 360
        if abs(a0 - a1) > 180:
            continue
        if (a0 - 0.0) * (a1 - 0.0) < 0 or a0 == 0:
            gm.append(-20 * math.log10(mag[k]))
    # phase margin: angle of L at |L|=1 measured from -180
    pms = []
    for k in range(len(w) - 1):
        if (mag[k] - 1) * (mag[k + 1] - 1) < 0:
            ang = math.degrees(np.angle(L[k]))  # -180..180
            pms.append(180 + ang if ang < 0 else 180 - ang if ang > 0 else 180)
            pms[-1] = ((ang + 180) % 360) if ang < 0 else -((180 - ang) % 360) + 0
    return (min(gm) if gm else float("inf")), pms


def stable(p, vel_hz, pos_hz, **kw):
    """Closed-loop stability from the discrete closed-loop poles of the cascade
    (exact, independent of the margin bookkeeping), and the margins."""
    T = p["loop_s"]
    w = np.logspace(0, math.log10(math.pi / T * 0.999), 6000)
    f = loop_frf(p, w, vel_hz, pos_hz, **kw)
    # Nyquist-based: count via the argument principle is fiddly; use margins on |L|
    mag = np.abs(f["L"])
    ang = np.degrees(np.angle(f["L"]))
    # gain margin: |L| where the phase crosses +-180
    gms = [-20 * math.log10(mag[k]) for k in range(len(w) - 1)
           if np.sign(np.sin(np.radians(ang[k]))) != np.sign(np.sin(np.radians(ang[k + 1])))
           and np.cos(np.radians(ang[k])) < 0]
    pms = [180 - abs(ang[k]) for k in range(len(w) - 1) if (mag[k] - 1) * (mag[k + 1] - 1) < 0]
    return w, f, (min(gms) if gms else float("inf")), (min(pms) if pms else float("inf"))


def closed_loop_poles(p, vel_hz, pos_hz, lpf_hz=None, two_way=True):
    """Characteristic polynomial of the sampled cascade: 1 + C Fl (F D + kv) G = 0."""
    T = p["loop_s"]
    jt = p["j_motor"] + p["j_table"] / p["i"] ** 2
    wv = TAU * vel_hz
    kp, ki, kv = jt * wv, jt * wv * wv / 4, TAU * pos_hz
    nd, dd = discrete_plant(p, T, two_way)
    a = 1 - math.exp(-TAU * p["filt_hz"] * T)
    # polynomials in z (descending)
    Cn = np.polyadd(np.polymul([kp], [1, -1]), [ki * T])      # (kp (z-1) + ki T) / (z-1)
    Cd = [1, -1]
    Fn, Fd = [a, 0], [1, -(1 - a)]                              # a z / (z - (1-a))
    Dn, Dd = [1 / T, -1 / T], [1, 0]                            # (z-1)/(T z)
    FDn = np.polymul(Fn, Dn)
    FDd = np.polymul(Fd, Dd)
    Hn = np.polyadd(FDn, np.polymul([kv], FDd))                 # F D + kv
    Hd = FDd
    Ln = np.polymul(np.polymul(Cn, Hn), nd)
    Ld = np.polymul(np.polymul(Cd, Hd), dd)
    if lpf_hz:
        wl = TAU * lpf_hz
        b, a2 = signal.bilinear([wl * wl], [1, 2 * 0.7 * wl, wl * wl], fs=1 / T)
        Ln, Ld = np.polymul(Ln, b), np.polymul(Ld, a2)
    char = np.polyadd(Ld, Ln)
    return np.roots(char)


def max_radius(p, vel_hz, pos_hz, **kw):
    return float(np.max(np.abs(closed_loop_poles(p, vel_hz, pos_hz, **kw))))


def error_frf(p, w, vel_hz, pos_hz, lpf_hz=None, two_way=True):
    """Following error (reference - motor angle)/reference with velocity feed-forward,
    on the loop samples, and the table angle / motor angle through the mesh."""
    f = loop_frf(p, w, vel_hz, pos_hz, lpf_hz=lpf_hz, two_way=two_way)
    T = p["loop_s"]
    z = np.exp(1j * w * T)
    # reference r (motor angle) -> ff = ff_gain * D r (the drive differences its targets)
    # u = C Fl (kv (r - y) + ff D r - F D y); y = G u
    # the drive differentiates its own interpolation segment exactly (servo.rs ff_rad_s)
    ff = p["ff"] * 1j * w
    num = f["C"] * f["Fl"] * (f["kv"] + ff) * f["G"]
    Tcl = num / (1 + f["L"])
    E = 1 - Tcl
    # table / motor through the compliant mesh (continuous, at w)
    s = 1j * w
    i = p["i"]
    tab = (p["c"] * s + p["k"]) / (p["j_table"] * s * s + p["c"] * s + p["k"])
    return E, Tcl, tab


def search(p, pos_ratio=None, lpf_hz=None, gm_min=6.0, pm_min=40.0):
    """Largest velocity bandwidth (rigid-tuned formula) with the stated margins on the
    velocity loop alone, then the largest position bandwidth keeping them on the cascade."""
    best = None
    for vel in np.arange(5, 401, 1.0):
        w, f, gm, pm = stable(p, vel, 0.0, lpf_hz=lpf_hz)
        # velocity loop alone: margins on Lv
        mag = np.abs(f["Lv"])
        ang = np.degrees(np.angle(f["Lv"]))
        gms = [-20 * math.log10(mag[k]) for k in range(len(w) - 1)
               if np.sign(ang[k]) != np.sign(ang[k + 1]) and abs(ang[k]) > 90]
        pms = [180 - abs(ang[k]) for k in range(len(w) - 1) if (mag[k] - 1) * (mag[k + 1] - 1) < 0]
        gmv = min(gms) if gms else 99
        pmv = min(pms) if pms else 99
        if max_radius(p, vel, 0.0, lpf_hz=lpf_hz) < 1 and gmv >= gm_min and pmv >= pm_min:
            best = (vel, gmv, pmv)
    return best


def gm_pm(L, w):
    """Upper gain margin (dB, at the -180 deg crossings where |L| < 1) and the phase
    margin (deg, the smallest at any 0 dB crossing), with their frequencies (Hz)."""
    mag = np.abs(L)
    ang = np.degrees(np.angle(L))
    gms = [(-20 * math.log10(mag[k]), w[k] / TAU) for k in range(len(w) - 1)
           if np.sign(ang[k]) != np.sign(ang[k + 1]) and abs(ang[k]) > 90 and mag[k] < 1]
    pms = [(180 - abs(ang[k]), w[k] / TAU) for k in range(len(w) - 1) if (mag[k] - 1) * (mag[k + 1] - 1) < 0]
    return (min(gms) if gms else (99, 0)), (min(pms) if pms else (99, 0)), pms


WGRID = None


def grid(p):
    T = p["loop_s"]
    return np.logspace(0, math.log10(math.pi / T * 0.999), 3000)


def vel_margins(p, vel, lpf_hz=None, two_way=True):
    w = grid(p)
    f = loop_frf(p, w, vel, 0.0, lpf_hz=lpf_hz, two_way=two_way)
    return gm_pm(f["Lv"], w)


def _old_vel_margins(p, vel, lpf_hz=None, two_way=True):
    T = p["loop_s"]
    w = np.logspace(0, math.log10(math.pi / T * 0.999), 8000)
    f = loop_frf(p, w, vel, 0.0, lpf_hz=lpf_hz, two_way=two_way)
    mag = np.abs(f["Lv"])
    ang = np.degrees(np.angle(f["Lv"]))
    gms = [(-20 * math.log10(mag[k]), w[k] / TAU) for k in range(len(w) - 1)
           if np.sign(ang[k]) != np.sign(ang[k + 1]) and abs(ang[k]) > 90]
    pms = [(180 - abs(ang[k]), w[k] / TAU) for k in range(len(w) - 1) if (mag[k] - 1) * (mag[k + 1] - 1) < 0]
    return (min(gms) if gms else (99, 0)), (min(pms) if pms else (99, 0)), pms


def cascade_margins(p, vel, pos, lpf_hz=None, two_way=True):
    w = grid(p)
    f = loop_frf(p, w, vel, pos, lpf_hz=lpf_hz, two_way=two_way)
    g, pm, _ = gm_pm(f["L"], w)
    return g, pm


def _old_cascade_margins(p, vel, pos, lpf_hz=None, two_way=True):
    T = p["loop_s"]
    w = np.logspace(0, math.log10(math.pi / T * 0.999), 8000)
    f = loop_frf(p, w, vel, pos, lpf_hz=lpf_hz, two_way=two_way)
    mag = np.abs(f["L"])
    ang = np.degrees(np.angle(f["L"]))
    gms = [(-20 * math.log10(mag[k]), w[k] / TAU) for k in range(len(w) - 1)
           if np.sign(ang[k]) != np.sign(ang[k + 1]) and abs(ang[k]) > 90]
    pms = [(180 - abs(ang[k]), w[k] / TAU) for k in range(len(w) - 1) if (mag[k] - 1) * (mag[k + 1] - 1) < 0]
    return (min(gms) if gms else (99, 0)), (min(pms) if pms else (99, 0))


def report(name, p):
    print(f"\n=== {name}: J_m {p['j_motor']:.3g}, J_t {p['j_table']}, k {p['k']:.3g}, c {p['c']:.0f} ===")
    for two_way in (False, True):
        for vel, pos in ((400, 60), (100, 15)):
            r = max_radius(p, vel, pos, two_way=two_way)
            (gm, fg), (pm, fp), _ = vel_margins(p, vel, two_way=two_way)
            (gmc, fgc), (pmc, fpc) = cascade_margins(p, vel, pos, two_way=two_way)
            print(f"  {'two-way' if two_way else 'one-way'} v {vel} Hz / p {pos} Hz: max |pole| {r:.4f} "
                  f"({'STABLE' if r < 1 else 'UNSTABLE'}); velocity loop GM {gm:.1f} dB @ {fg:.0f} Hz, "
                  f"PM {pm:.1f} deg @ {fp:.0f} Hz; cascade GM {gmc:.1f} dB, PM {pmc:.1f} deg @ {fpc:.0f} Hz")
    # the largest stable bandwidth, and with margins, with and without a torque low-pass
    for lpf in (None, 800.0):
        lim = None
        ok = None
        for vel in np.arange(2, 402, 4.0):
            r = max_radius(p, vel, 0.0, lpf_hz=lpf)
            if r < 1:
                lim = vel
            (gm, _), (pm, _), _ = vel_margins(p, vel, lpf_hz=lpf)
            if r < 1 and gm >= 6 and pm >= 45:
                ok = (vel, gm, pm)
        print(f"  torque LPF {lpf or 'none'}: velocity loop stable up to {lim} Hz; "
              f"with GM>=6 dB, PM>=45 deg up to {ok[0] if ok else None} Hz "
              f"(GM {ok[1]:.1f} dB, PM {ok[2]:.1f} deg)" if ok else f"  torque LPF {lpf}: none")
    return


def proposal(p, vel, lpf=None):
    """Largest position bandwidth with cascade GM >= 6 dB, PM >= 40 deg and a closed-loop
    peak of the following below 2 dB."""
    best = None
    for pos in np.arange(1, 61, 1.0):
        r = max_radius(p, vel, pos, lpf_hz=lpf)
        (gm, _), (pm, _) = cascade_margins(p, vel, pos, lpf_hz=lpf)
        if r < 1 and gm >= 6 and pm >= 40:
            best = (pos, gm, pm)
    return best


if __name__ == "__main__":
    ship = P.shipped()
    der = P.derived()
    light = dict(der, j_table=6.0)
    light["c"] = 2 * 0.05 * math.sqrt(light["k"] * P.modes(light["j_motor"], 6.0, light["k"])["j_red"])
    for name, p in (("shipped (plant.toml numbers, worm.rs damping)", ship),
                    ("derived (worm+coupling on the motor, modal zeta 5 %)", der),
                    ("derived, 6 kg m2 table (500 mm table estimate)", light)):
        report(name, p)
    print("\n=== proposed tunings (rigid formula kp = J_tot w_v, ki = J_tot w_v^2/4, FF 1) ===")
    for name, p in (("shipped", ship), ("derived", der), ("derived 6 kg m2", light)):
        for lpf in (None, 500.0):
            ok = None
            for vel in np.arange(2, 402, 4.0):
                (gm, _), (pm, _), _ = vel_margins(p, vel, lpf_hz=lpf)
                if max_radius(p, vel, 0.0, lpf_hz=lpf) < 1 and gm >= 6 and pm >= 45:
                    ok = vel
            if ok is None:
                print(f"  {name} LPF {lpf}: no velocity tuning with margins")
                continue
            pos = proposal(p, ok, lpf)
            (gm, fg), (pm, fp), _ = vel_margins(p, ok, lpf_hz=lpf)
            jt = p["j_motor"] + p["j_table"] / p["i"] ** 2
            print(f"  {name}, torque LPF {lpf}: velocity {ok:.0f} Hz (kp {jt*TAU*ok:.3f} Nm s/rad; "
                  f"GM {gm:.1f} dB @ {fg:.0f} Hz, PM {pm:.1f} deg @ {fp:.0f} Hz); position up to "
                  + (f"{pos[0]:.1f} Hz (cascade GM {pos[1]:.1f} dB, PM {pos[2]:.1f} deg)" if pos else "none"))
    # Following error at hobbing speeds
    print("\n=== following error (motor angle -> table arcsec) ===")
    T = ship["loop_s"]
    for name, p, vel, pos, lpf in (("shipped tuning 400/60 on one-way plant", ship, 400, 60, None),
                                   ("50/20 Hz on shipped numbers, two-way", ship, 50, 20, None),
                                   ("74/16 Hz on derived plant", der, 74, 16, None),
                                   ("170/29 Hz on derived 6 kg m2 table", light, 170, 29, None)):
        two = name.find("one-way") < 0
        for case, n_c, gashes, z, ripple in (("thesis ex. v_c 30 D80 z17", 119.37, 10, 17, 0.005),
                                             ("worst v_c 40 D60 z15", 212.2, 10, 15, 0.005),
                                             ("worst, 2 % ripple", 212.2, 10, 15, 0.02)):
            n_b = n_c / z
            wb = n_b / 60 * TAU            # table rad/s
            fg = n_c * gashes / 60         # gash frequency, Hz
            # table angle ripple from spindle speed ripple at fg: amplitude delta*wb / (2 pi fg)
            amp = ripple * wb / (TAU * fg) / ARCSEC
            w = np.array([TAU * fg])
            E, Tcl, tab = error_frf(p, w, vel, pos, lpf_hz=lpf, two_way=two)
            # table angle relative to the reference: T_cl * tab
            table_err = abs(1 - Tcl[0] * tab[0]) * amp   # the table hangs on the mesh in both plants
            lag_noff = wb / (TAU * pos) / ARCSEC
            print(f"  {name}: {case}: table {n_b:.2f} rpm, gash {fg:.1f} Hz, ripple {ripple*100:.1f} % "
                  f"-> reference ripple {amp:.2f} arcsec; motor error {abs(E[0])*amp:.2f} arcsec, "
                  f"table error {table_err:.2f} arcsec (|table/motor| {abs(tab[0]):.2f}); "
                  f"without FF the lag would be {lag_noff:.0f} arcsec")
        # equivalent low-frequency delay of the servo (group delay of Tcl at 1 Hz)
        w = TAU * np.array([0.5, 1.0])
        E, Tcl, _ = error_frf(p, w, vel, pos, lpf_hz=lpf, two_way=two)
        gd = -(np.angle(Tcl[1]) - np.angle(Tcl[0])) / (w[1] - w[0])
        print(f"    servo's own group delay at 1 Hz: {gd*1e6:.1f} us")
    if "--plot" in sys.argv:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        w = np.logspace(math.log10(TAU * 5), math.log10(math.pi / T * 0.999), 3000)
        fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
        for lab, p, vel, lpf, tw in (("shipped 400 Hz, one-way", ship, 400, None, False),
                                     ("shipped 400 Hz, two-way", ship, 400, None, True),
                                     ("40 Hz, two-way (derived)", der, 40, None, True)):
            f = loop_frf(p, w, vel, 0.0, lpf_hz=lpf, two_way=tw)
            ax[0].semilogx(w / TAU, 20 * np.log10(np.abs(f["Lv"])), label=lab)
            ax[1].semilogx(w / TAU, np.degrees(np.angle(f["Lv"])), label=lab)
        ax[0].axhline(0, color="k", lw=0.5)
        ax[0].set_ylabel("|L_v| dB")
        ax[1].set_ylabel("phase deg")
        ax[1].set_xlabel("Hz")
        ax[0].legend()
        fig.savefig("docs/mechanism-bode.png", dpi=90)
        print("wrote docs/mechanism-bode.png")

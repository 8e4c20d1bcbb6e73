"""Issue 33: the thesis machine's table drive numbers for a two-way coupled model.

Run: python3 bench/side-model/params.py
Every number is tagged: [seed] thesis/seed text, [config] shipped config/*.toml,
[formula] a standard formula with stated inputs, [assumed] an engineering assumption.
Other scripts import `shipped()` and `derived()`.
"""
import math

TAU = 2 * math.pi
ARCSEC = math.pi / 180 / 3600


def cyl_inertia(d_m, l_m, rho=7850.0, d_in=0.0):
    """Polar moment of inertia of a (hollow) cylinder, kg m2."""
    return math.pi / 32 * rho * l_m * (d_m**4 - d_in**4)


def mesh():
    """Torsional stiffness at the table of the worm drive, Nm/rad, parts in series."""
    r = 0.150                       # wheel pitch radius [config] d 300 mm (itself assumed)
    alpha_n = math.radians(20)      # [assumed] standard ZA/ZI worm, 20 deg
    m, q = 4.0, 10.0                # module [config: 300/75]; diameter quotient [assumed, DIN 3976]
    d1 = q * m / 1000               # worm reference diameter 40 mm
    gamma = math.atan(1 / q)        # lead angle, single start: 5.7 deg
    # ISO 6336-1: single stiffness c' ~ 14 N/(mm um) steel/steel, scaled by the
    # equivalent modulus E = 2 E1 E2/(E1+E2) (steel 206 GPa, tin bronze CuSn12 ~ 98 GPa).
    e_eq = 2 * 206 * 98 / (206 + 98)
    c1 = 14.0 * e_eq / 206
    eps = 2.0                       # [assumed] worm-gear contact ratio 1.8-2.2
    c_gamma = c1 * (0.75 * eps + 0.25)      # ISO 6336-1 mesh stiffness, N/(mm um)
    b = 30.0                        # [assumed] effective contact width, mm (b2 ~ 0.75 d_a1 = 36)
    k_normal = c_gamma * b * 1e6    # N/m along the line of action
    k_tan = k_normal * (math.cos(alpha_n) * math.cos(gamma)) ** 2
    parts = {
        "tooth mesh (ISO 6336-1 c_gamma, steel/bronze, b 30 mm)": k_tan * r * r,
        # The wheel's tangential force is the worm's axial force: the worm's axial
        # bearings (a preloaded angular-contact pair, catalogue 100-250 N/um) carry it.
        "worm axial bearings 150 N/um [catalogue range, assumed]": 150e6 * r * r,
        "worm shaft compression (d 30, 60 mm) [formula]": 2.1e11 * math.pi / 4 * 0.03**2 / 0.06 * r * r,
        "worm shaft torsion (d 25, 150 mm) x i^2 [formula]": 80e9 * math.pi * 0.025**4 / 32 / 0.15 * 75**2,
        "bellows coupling 1e4 Nm/rad x i^2 [catalogue, assumed]": 1e4 * 75**2,
        "wheel rim/hub and its bolted joint to the table [assumed]": 2e7,
    }
    k_series = 1 / sum(1 / v for v in parts.values())
    return parts, k_series, dict(c_gamma=c_gamma, k_tan=k_tan, d1=d1, gamma=gamma)


def inertias():
    worm = cyl_inertia(0.040, 0.062) + cyl_inertia(0.025, 0.20)   # worm body + journals [formula]
    coupling = 0.3e-4                                              # [assumed] bellows for a 0.4 kW motor
    table_disk = cyl_inertia(0.50, 0.10)                           # 500 mm x 100 mm steel table [assumed]
    wheel = cyl_inertia(0.31, 0.045, rho=8800, d_in=0.24) + cyl_inertia(0.24, 0.03, rho=7200)
    return dict(worm=worm, coupling=coupling, table_disk=table_disk, wheel=wheel)


def modes(j_motor, j_table, k, i=75.0, c=None, zeta=None):
    """Anti-resonance (motor locked... i.e. zero of motor-side FRF) and resonance, Hz;
    the modal damping for a relative damper c (Nm s/rad at the table)."""
    jm_t = j_motor * i * i                   # motor side reflected to the table
    w_a = math.sqrt(k / j_table)
    j_red = jm_t * j_table / (jm_t + j_table)
    w_r = math.sqrt(k / j_red)
    out = dict(f_anti=w_a / TAU, f_res=w_r / TAU, ratio=w_r / w_a, j_red=j_red,
               inertia_ratio=j_table / jm_t)
    if c is not None:
        out["zeta_modal"] = c / (2 * math.sqrt(k * j_red))
    return out


def shipped():
    """What bench/plant uses today (config/plant.toml, machine.toml)."""
    k, jt, zt = 2.0e6, 20.0, 0.05
    return dict(j_motor=0.00034, j_table=jt, i=75.0, k=k, c=2 * zt * math.sqrt(k * jt),
                backlash_arcsec=10.0, peak_nm=5.7, friction_motor_nm=0.05,
                bearing_nm=10.0, loop_s=200e-6, filt_hz=1500.0, fb_counts=2**20,
                vel_hz=400.0, pos_hz=60.0, ff=1.0, period_s=1e-3)


def derived():
    """The two-way model proposed here: the worm and coupling on the motor side, the
    damper defined by the coupled mode's damping (5 %)."""
    p = shipped()
    inn = inertias()
    p["j_motor"] = 0.00034 + inn["worm"] + inn["coupling"]
    _, k, _ = mesh()
    p["k"] = round(k, -5)
    jm_t = p["j_motor"] * 75**2
    j_red = jm_t * p["j_table"] / (jm_t + p["j_table"])
    p["c"] = 2 * 0.05 * math.sqrt(p["k"] * j_red)
    return p


if __name__ == "__main__":
    print("== thesis (seed 000) figures checked ==")
    n_gv = 40 / (0.060 * math.pi)
    print(f"n_GV = v_c/(pi D) = {n_gv:.2f} rpm (thesis 212.2)")
    print(f"n_B = {n_gv:.2f}/15 = {n_gv/15:.3f} rpm (thesis 14.1); motor = {n_gv/15*75:.1f} rpm "
          f"(thesis eq. 4.16: 1057.5, its text 1057.7; both use the rounded 14.1)")
    print(f"M = 1.9 Nm x 75 = {1.9*75:.1f} Nm (thesis 142.5: rated, not peak; peak 5.7 x 75 = {5.7*75:.1f}"
          f" Nm before worm losses, eta ~0.5-0.7 at i = 75 per thesis ch.1)")
    ke = 45 / 1000 / (TAU / 60)
    print(f"K_E 45 V/krpm = {ke:.3f} V s/rad -> K_T ~ sqrt(3) K_E = {math.sqrt(3)*ke:.3f} Nm/A; "
          f"table 6: 1.9/2.5 = {1.9/2.5:.2f}, 5.7/7.5 = {5.7/7.5:.2f} Nm/A (consistent)")
    print("\n== seed 003 figures checked ==")
    t1, t2 = 0.008, 0.0001
    print(f"table link T1 0.008 s -> {1/(TAU*t1):.1f} Hz; zeta = T2/(2 T1) = {t2/(2*t1):.4f} "
          f"(eq. 8 with lambda 0.3 would give T2 = {0.3/math.pi*t1:.5f} s, zeta {0.3/(2*math.pi):.3f});"
          f" the text says the table rings 'of order 10 Hz'")
    c_tool = 3 * 2.1e5 * 2.5**3 / 100**2
    print(f"tool link eq.6: C = 3 E b^3/R_a^2 = {c_tool:.0f} N/mm (seed: 3 kN/mm); "
          f"T1 = sqrt(10 kg/3 kN/mm) = {math.sqrt(10/3e6)*1e3:.2f} ms (seed 58 ms); "
          f"1/(2 pi 0.058) = {1/(TAU*0.058):.2f} Hz (seed 12.6); second cutter: "
          f"C = {3*2.1e5*4**3/80**2:.0f} N/mm, T1 = {math.sqrt(10/(3*2.1e5*4**3/80**2*1e3))*1e3:.2f} ms "
          f"(seed 0.0126 s, and 1/(2 pi 0.0126) = {1/(TAU*0.0126):.1f} Hz is where its 12.6 Hz comes from)")
    print("\n== inertias ==")
    inn = inertias()
    for k_, v in inn.items():
        print(f"  {k_:12s} {v:.3g} kg m2  (at motor: {v/75**2 if 'table' in k_ or k_=='wheel' else v:.3g})")
    print("\n== torsional stiffness at the table ==")
    parts, ks, aux = mesh()
    print(f"  c_gamma = {aux['c_gamma']:.1f} N/(mm um), tangential mesh {aux['k_tan']/1e6:.0f} N/um, "
          f"lead angle {math.degrees(aux['gamma']):.2f} deg")
    for k_, v in parts.items():
        print(f"  {v:10.3g} Nm/rad  {v*ARCSEC*60:9.0f} Nm/arcmin  {k_}")
    print(f"  series: {ks:.3g} Nm/rad = {ks*ARCSEC*60:.0f} Nm/arcmin (shipped 2.0e6 = "
          f"{2e6*ARCSEC*60:.0f} Nm/arcmin)")
    print("\n== modes seen at the motor ==")
    for name, p in (("shipped", shipped()), ("derived", derived())):
        m = modes(p["j_motor"], p["j_table"], p["k"], c=p["c"])
        print(f"  {name}: J_motor side {p['j_motor']:.3g} kg m2, J_table {p['j_table']} kg m2, "
              f"k {p['k']:.3g}, c {p['c']:.0f} Nm s/rad (at table)")
        print(f"    anti-resonance {m['f_anti']:.1f} Hz, resonance {m['f_res']:.1f} Hz, "
              f"J_L/J_M = {m['inertia_ratio']:.2f}, modal zeta {m['zeta_modal']:.3f}")
    for jt in (5.0, 10.0, 20.0):
        for k in (1e6, 2e6, 5e6):
            m = modes(derived()["j_motor"], jt, k)
            print(f"    J_table {jt:4.0f}, k {k:.0e}: anti {m['f_anti']:5.1f} Hz, res {m['f_res']:5.1f} Hz")
    p = shipped()
    print(f"\n  coupling mode (motor 3.4e-4 | worm {inn['worm']:.2e} on 1e4 Nm/rad): "
          f"{math.sqrt(1e4*(1/3.4e-4+1/inn['worm']))/TAU:.0f} Hz")
    print(f"  static windup under 10 Nm bearing + 3.4 Nm cut at the table: "
          f"{13.4/2e6/ARCSEC:.2f} arcsec")

#!/usr/bin/python3
"""Writes the synthetic rheometer log samples of tests/data/logs (deterministic).

All files hold the same waveforms (see README.md): two intervals with deflection
amplitudes PHI0 = 0.05 and 0.2 rad at F = 0.1 Hz, 3 cycles of 25 points each
(dt = 0.4 s), phi(t) = PHI0 sin(w t), torque = K phi + C dphi/dt. Interval 2 starts at
t = 40 s (4 periods later, so the same phase). Values are written with 6 significant
digits in each file's own units.

Run from anywhere: /usr/bin/python3 tests/data/logs/make_logs.py
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))

F_HZ = 0.1
W = 2 * math.pi * F_HZ
K_N_M_PER_RAD = 4e-3
C_N_M_S_PER_RAD = 2e-3
AMPLITUDES_RAD = [0.05, 0.2]
STARTS_S = [0.0, 40.0]
POINTS = 75
DT_S = 0.4
STRAIN_CONSTANT_PER_RAD = 1.5
STRESS_CONSTANT_PA_PER_N_M = 12000.0


def samples():
    """[(interval, t_s, phi_rad, torque_N_m)] for both intervals."""
    out = []
    for k, (phi0, t0) in enumerate(zip(AMPLITUDES_RAD, STARTS_S)):
        for i in range(POINTS):
            t = t0 + DT_S * i
            phase = W * DT_S * i  # t0 is a whole number of periods
            phi = phi0 * math.sin(phase)
            dphi = phi0 * W * math.cos(phase)
            out.append((k + 1, t, phi, K_N_M_PER_RAD * phi + C_N_M_S_PER_RAD * dphi))
    return out


def g6(x, comma=False):
    s = "%.6g" % x
    if s in ("-0", "0"):
        s = "0"
    return s.replace(".", ",") if comma else s


def t1(x, comma=False):
    s = "%.1f" % x
    return s.replace(".", ",") if comma else s


def write(name, text, encoding="utf-8", newline="\n"):
    data = text.replace("\n", newline).encode(encoding)
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def generic_csv():
    lines = ["# source: synthetic sample written by tests/data/logs/make_logs.py",
             "# N: 45",
             "# omega_rad_per_s: %r" % W,
             "interval,time_s,angle_rad,torque_N_m"]
    for k, t, phi, tau in samples():
        lines.append("%d,%s,%s,%s" % (k, t1(t), g6(phi), g6(tau)))
    write("generic.csv", "\n".join(lines) + "\n")


def generic_tsv():
    lines = ["Interval\tTime [ms]\tAngle [mrad]\tTorque [mN\u00b7m]"]
    for k, t, phi, tau in samples():
        lines.append("%d\t%d\t%s\t%s" % (k, round(t * 1000), g6(phi * 1e3, True),
                                         g6(tau * 1e3, True)))
    write("generic_mrad_mNm.tsv", "\n".join(lines) + "\n")


def angle_sampled():
    lines = ["# no time column: a logger triggered every delta-phi",
             "segment,angle_deg,torque_uN_m"]
    for k, t, phi, tau in samples():
        lines.append("%d,%s,%s" % (k, g6(math.degrees(phi)), g6(tau * 1e6)))
    write("angle_sampled.csv", "\n".join(lines) + "\n")


def strain_stress():
    lines = ["# strain = %g/rad * angle, stress = %g Pa/(N m) * torque"
             % (STRAIN_CONSTANT_PER_RAD, STRESS_CONSTANT_PA_PER_N_M),
             "interval,time_s,strain_pct,stress_Pa"]
    for k, t, phi, tau in samples():
        lines.append("%d,%s,%s,%s" % (k, t1(t), g6(100 * STRAIN_CONSTANT_PER_RAD * phi),
                                      g6(STRESS_CONSTANT_PA_PER_N_M * tau)))
    write("generic_strain_stress.csv", "\n".join(lines) + "\n")


def anton_paar_en():
    # Names on the "Interval data:" line, a second name row, a units row; UTF-16 LE.
    lines = ["Project:\tshearzone samples", "Test:\tLAOS raw data (synthetic)",
             "Result:\tsample 1", ""]
    for k in (1, 2):
        rows = [s for s in samples() if s[0] == k]
        lines += ["Interval and data points:\t%d\t%d" % (k, len(rows)),
                  "Interval data:\tPoint No.\tTime\tDeflection\tTorque\tStatus",
                  "\t\t\tAngle\t\t",
                  "\t\t[s]\t[mrad]\t[\u00b5Nm]\t"]
        for i, (_, t, phi, tau) in enumerate(rows):
            lines.append("\t%d\t%s\t%s\t%s\tDy_auto" % (i + 1, t1(t, True), g6(phi * 1e3, True),
                                                     g6(tau * 1e6, True)))
        lines.append("")
    write("anton_paar_en_utf16.txt", "\ufeff" + "\n".join(lines) + "\n", "utf-16-le", "\r\n")


def anton_paar_de():
    # Names on the line after "Intervalldaten:", interval time restarting at 0, degrees.
    lines = ["Projekt:\tshearzone Beispiele", "Test:\tLAOS Rohdaten (synthetisch)",
             "Ergebnis:\tProbe 1", ""]
    for k in (1, 2):
        rows = [s for s in samples() if s[0] == k]
        lines += ["Intervalle und Messpunkte:\t%d\t%d" % (k, len(rows)),
                  "Intervalldaten:",
                  "\tMesspunkt\tIntervallzeit\tAuslenkwinkel\tDrehmoment",
                  "\t\t[s]\t[\u00b0]\t[mN\u00b7m]"]
        t0 = rows[0][1]
        for i, (_, t, phi, tau) in enumerate(rows):
            lines.append("\t%d\t%s\t%s\t%s" % (i + 1, t1(t - t0, True),
                                              g6(math.degrees(phi), True), g6(tau * 1e3, True)))
        lines.append("")
    write("anton_paar_de_utf8.txt", "\n".join(lines) + "\n", "utf-8", "\r\n")


def anton_paar_fr():
    lines = ["Projet:\tshearzone exemples", "Essai:\tLAOS donn\u00e9es brutes (synth\u00e9tiques)",
             ""]
    for k in (1, 2):
        rows = [s for s in samples() if s[0] == k]
        lines += ["Donn\u00e9es d'intervalle:\tN\u00b0 de point\tTemps\tAngle de d\u00e9viation"
                  "\tCouple",
                  "\t\t[s]\t[rad]\t[\u00b5N\u00b7m]"]
        for i, (_, t, phi, tau) in enumerate(rows):
            lines.append("\t%d\t%s\t%s\t%s" % (i + 1, t1(t, True), g6(phi, True),
                                              g6(tau * 1e6, True)))
        lines.append("")
    write("anton_paar_fr.txt", "\ufeff" + "\n".join(lines) + "\n", "utf-8", "\r\n")


# Closed-cycle points (RheoCompass "one period per measuring point"): strain amplitude,
# G'_1, G''_1, G'_3, G''_3 (Pa) per point; N_PER_PERIOD samples plus the closing one.
POINTS_FR = [(0.01, 50.0, 9.0, 0.0, 0.0), (0.1, 40.0, 10.0, 0.5, 0.2), (1.0, 20.0, 12.0, 2.0, -1.0)]
N_PER_PERIOD = 64
PSI_RAD = -0.3        # phase of the stored period's first sample
F_POINTS_HZ = 0.3


def point_samples(g0, g1p, g1pp, g3p, g3pp):
    """[(strain, stress_Pa)] of one closed period: N_PER_PERIOD + 1 samples."""
    out = []
    for k in range(N_PER_PERIOD + 1):
        th = 2 * math.pi * (k % N_PER_PERIOD) / N_PER_PERIOD + PSI_RAD
        out.append((g0 * math.sin(th),
                    g0 * (g1p * math.sin(th) + g1pp * math.cos(th) +
                          g3p * math.sin(3 * th) + g3pp * math.cos(3 * th))))
    return out


def anton_paar_fr_points():
    head = ("\tPoint No.\tTemps\tIntervalle Temps\tContrainte de Cisaillement\tFr\u00e9quence"
            "\tD\u00e9formation de Cisaillement\tModule de Stockage\tModule de Perte\tCouple"
            "\tEtat\tD\u00e9formation de Cisaillement (pour d\u00e9formation sinuso\u00efdale)"
            "\tContrainte de Cisaillement (pour d\u00e9formation sinuso\u00efdale)")
    names2 = "\t" * 11 + "Sinuso\u00efdes\tSinuso\u00efdes"
    units = "\t\t[s]\t[s]\t[Pa]\t[Hz]\t[%]\t[Pa]\t[Pa]\t[mN\u00b7m]\t\t[1]\t[Pa]"
    lines = ["Projet:\tshearzone exemples", "", "Test:\tLAOS par points (synth\u00e9tique)", "",
             "R\u00e9sultat:\tFlow Curve 1", "",
             "Intervalle et points de donn\u00e9es:\t1\t3",
             "Interval donn\u00e9es:" + head, names2, units]
    for i in range(3):  # a flow curve: one row per point, no waveform (skipped)
        lines.append("\t%d\t%d\t%d\t%s\t\t%s\t\t\t%s\tDy_auto\t\t" % (
            i + 1, i + 1, i + 1, g6(70.0 - i, True), g6(2e4 * (i + 1), True), g6(2.4 - 0.01 * i, True)))
    lines += ["", "R\u00e9sultat:\tLAOS 1", "",
              "Intervalle et points de donn\u00e9es:\t3\t%d" % len(POINTS_FR),
              "Interval donn\u00e9es:" + head, names2, units]
    for p, (g0, g1p, g1pp, g3p, g3pp) in enumerate(POINTS_FR):
        wave = point_samples(g0, g1p, g1pp, g3p, g3pp)
        # The instrument's own moduli differ slightly from the harmonic ones (its method).
        point = "\t%d\t%d\t%d\t%s\t%s\t%s\t%s\t%s\t%s\tTruStrain\u2122" % (
            p + 1, 250 + 20 * p, 20 * (p + 1), g6(g0 * math.hypot(g1p, g1pp), True),
            g6(F_POINTS_HZ, True), g6(100 * g0, True), g6(1.003 * g1p, True),
            g6(0.997 * g1pp, True), g6(0.0327 * g0 * math.hypot(g1p, g1pp), True))
        for k, (g, sig) in enumerate(wave):
            cells = "\t%s\t%s" % (g6(g, True), g6(sig, True))
            lines.append((point if k == 0 else "\t" * 10) + cells)
    lines.append("")
    write("anton_paar_fr_points_utf16.txt", "\ufeff" + "\n".join(lines) + "\n", "utf-16-le",
          "\r\n")


# Malvern rSpace look-alike: torque-controlled oscillation, tau = T0 sin(w t), the angle
# lagging by delta with |K*| = hypot(K', K'') and creeping linearly; times printed with
# 4 significant digits (ties above 100 s).
MALVERN_K = (0.06, 0.005)       # K', K'' in N m/rad
MALVERN_T0 = 2e-5               # N m
MALVERN_F = 0.04                # Hz
MALVERN_DT = 0.078125           # s
MALVERN_CYCLES = 4.5
MALVERN_CREEP = 0.03            # of phi0 per cycle


def sig4(x):
    """A number as rSpace prints it: 4 significant digits, decimal comma."""
    if x == 0:
        return "0,000"
    e = math.floor(math.log10(abs(x)))
    if -2 <= e <= 3:
        return ("%.*f" % (max(0, 3 - e), x)).replace(".", ",")
    return ("%.3E" % x).replace(".", ",").replace("E-0", "E-00").replace("E+0", "E+00")


def malvern():
    cols = ["Action Name", "Time (sequence)(s)", "Time (action)(s)", "Shear stress(Pa)",
            "Shear rate(s-\u00b9)", "Frequency(Hz)", "Shear modulus (elastic component)(Pa)",
            "Shear modulus (viscous component)(Pa)", "Torque(N m)", "Angular displacement(rad)",
            "Temperature(\u00b0C)"]
    lines = [";".join(cols)]
    seq = 100.0
    for k in range(20):  # pre-shear: a steady rotation, no frequency
        t = 1.0 * (k + 1)
        lines.append("Pre Shear;%s;%s;30,00;47,00;;;;%s;%s;21,00" % (
            sig4(seq + t), sig4(t), sig4(1.2e-3), sig4(4.5 * t)))
    seq += 20
    for k in range(5):  # an amplitude table: summary rows only
        lines.append("Oscillation Amplitude Table;%s;%s;;;1,000;150,0;1,000;%s;%s;21,00" % (
            sig4(seq + 10 * k), sig4(10.0 * (k + 1)), sig4(5e-7 * (k + 1)), sig4(8e-6 * (k + 1))))
    seq += 50
    kp, kpp = MALVERN_K
    kabs = math.hypot(kp, kpp)
    delta = math.atan2(kpp, kp)
    phi0 = MALVERN_T0 / kabs
    w = 2 * math.pi * MALVERN_F
    n = int(round(MALVERN_CYCLES / MALVERN_F / MALVERN_DT))
    for k in range(1, n + 1):
        t = k * MALVERN_DT
        tau = MALVERN_T0 * math.sin(w * t)
        phi = phi0 * math.sin(w * t - delta) + MALVERN_CREEP * phi0 * MALVERN_F * t
        lines.append("Oscillation Single Frequency;%s;%s;;;;;;%s;%s;21,00" % (
            sig4(seq + t), sig4(t), sig4(tau), sig4(phi)))
    for k in range(1, 6):  # the summary rows appended after the action: time restarts
        t = 20.0 * k
        lines.append("Oscillation Single Frequency;%s;%s;;;%s;%s;%s;%s;%s;21,00" % (
            sig4(seq + t), sig4(t), sig4(MALVERN_F), sig4(1000 * kp * 1.01), sig4(1000 * kpp * 0.98),
            sig4(MALVERN_T0), sig4(phi0)))
    write("malvern_rspace.csv", "\n".join(lines) + "\n")


def anton_paar_de_points():
    """German RheoCompass, angle and torque waveform points: two columns named
    "Drehmoment" (the point's amplitude and the waveform), a "Periodenzeit" restarting at
    0 on each point; point 1 one closed period (64 + 1 samples), point 2 two periods of
    the first interval's waveform (not closed: timed)."""
    head = ("\tMesspunkt\tZeit\tFrequenz\tSpeichermodul\tVerlustmodul\tDrehmoment"
            "\tPeriodenzeit\tAuslenkwinkel\tDrehmoment")
    lines = ["Projekt:\tshearzone Beispiele", "", "Ergebnis:\tLAOS 1", "",
             "Intervall und Datenpunkte:\t2\t2", "Intervalldaten:" + head,
             "\t" * 7 + "Schwingungsverlauf\tSchwingungsverlauf\tSchwingungsverlauf",
             "\t\t[s]\t[Hz]\t[Pa]\t[Pa]\t[mN\u00b7m]\t[s]\t[mrad]\t[mN\u00b7m]"]
    phi0 = AMPLITUDES_RAD[0]
    amp = phi0 * math.hypot(K_N_M_PER_RAD, C_N_M_S_PER_RAD * W)
    for p, (n, periods) in enumerate([(N_PER_PERIOD, 1), (50, 2)]):
        point = "\t%d\t%d\t%s\t%s\t%s\t%s" % (p + 1, 100 + 50 * p, g6(F_HZ, True), g6(123.0, True),
                                              g6(45.6, True), g6(amp * 1e3, True))
        for k in range(n * periods + (1 if periods == 1 else 0)):
            t = k / (n * F_HZ)
            phi = phi0 * math.sin(W * t)
            tau = K_N_M_PER_RAD * phi + C_N_M_S_PER_RAD * phi0 * W * math.cos(W * t)
            cells = "\t%s\t%s\t%s" % (g6(t, True), g6(phi * 1e3, True), g6(tau * 1e3, True))
            lines.append((point if k == 0 else "\t" * 6) + cells)
    lines.append("")
    write("anton_paar_de_points.txt", "\n".join(lines) + "\n", "utf-8", "\r\n")


def trios():
    lines = ["Filename\tsample.tri", "Instrument name\tsynthetic", "",
             "[Geometry]", "Geometry name\t40 mm parallel plate (synthetic)",
             "Stress constant\t%g Pa/N.m" % STRESS_CONSTANT_PA_PER_N_M,
             "Strain constant\t%g 1/rad" % STRAIN_CONSTANT_PER_RAD, ""]
    for k in (1, 2):
        rows = [s for s in samples() if s[0] == k]
        lines += ["[step]", "Oscillation amplitude - %d" % k,
                  "Time\tOscillation displacement\tTorque\tOscillation strain\tOscillation stress",
                  "s\trad\t\u00b5N.m\t%\tPa"]
        for _, t, phi, tau in rows:
            lines.append("%s\t%s\t%s\t%s\t%s" % (
                t1(t), g6(phi), g6(tau * 1e6), g6(100 * STRAIN_CONSTANT_PER_RAD * phi),
                g6(STRESS_CONSTANT_PA_PER_N_M * tau)))
        lines.append("")
    write("trios.txt", "\n".join(lines), "utf-8", "\r\n")


def trios_csv():
    """TRIOS's CSV export: the text export's twin with ',' cells, plus a step without a
    drive (peak hold) and a summary step (amplitude sweep), both skipped."""
    lines = ["Filename,sample.tri", "Instrument name,synthetic", "",
             "[Geometry Parameters]", "Name,40 mm parallel plate (synthetic)",
             "Stress constant,%g Pa/N.m" % STRESS_CONSTANT_PA_PER_N_M,
             "Strain constant,%g 1/rad" % STRAIN_CONSTANT_PER_RAD, "",
             "[step]", "Peak hold - 1", "Stress,Shear rate,Viscosity,Step time",
             "Pa,1/s,Pa.s,s", "10.0,1.0,10.0,1.0", "10.0,1.0,10.0,2.0", ""]
    for k in (1, 2):
        rows = [s for s in samples() if s[0] == k]
        lines += ["[step]", "Oscillation amplitude - %d" % (k + 1),
                  "Time,Oscillation displacement,Torque", "s,rad,\u00b5N.m"]
        for _, t, phi, tau in rows:
            lines.append("%s,%s,%s" % (t1(t), g6(phi), g6(tau * 1e6)))
        lines.append("")
    lines += ["[step]", "Amplitude sweep - 4",
              "Storage modulus,Loss modulus,Oscillation torque,Oscillation displacement",
              "Pa,Pa,\u00b5N.m,rad", "100,10,1.0,0.001", "90,12,2.0,0.002", ""]
    write("trios_export.csv", "\n".join(lines), "utf-8", "\r\n")


def trios_lims():
    """TRIOS "LIMS export format": key rows per [Step]; a constant in g.cm; one step of
    raw samples (the first interval of the common waveforms) and a summary step."""
    lines = ["[Version]", "TA Instruments LIMS export format version\t0", "[Geometry: Standard]",
             "Name\tsynthetic", "Stress constant\t1.17680 Pa/g.cm", "Strain constant\t1.5 1/rad",
             "[Step]", "Step name\tOscillation amplitude (raw)", "Number of points\t%d" % POINTS,
             "Variables\tStep time\tOscillation displacement\tOscillation torque",
             "Units\ts\trad\t\u00b5N.m"]
    for k, t, phi, tau in samples():
        if k == 1:
            lines.append("Data point\t%s\t%s\t%s" % (t1(t), g6(phi), g6(tau * 1e6)))
    lines += ["[Step]", "Step name\tFrequency sweep (25.0 \u00b0C)", "Number of points\t2",
              "Variables\tAngular frequency\tStorage modulus\tLoss modulus",
              "Units\trad/s\tPa\tPa", "Data point\t1.0\t100\t10", "Data point\t2.0\t110\t12"]
    write("trios_lims.txt", "\n".join(lines) + "\n", "utf-8", "\r\n")


def reptate():
    # RepTate .laos: one amplitude per file (interval 1 only).
    lines = ["omega=%r;gamma=%r;" % (W, AMPLITUDES_RAD[0]), "#time\tq\tTorque", "#s\trad\tN-m"]
    for k, t, phi, tau in samples():
        if k == 1:
            lines.append("%s\t%s\t%s" % (t1(t), g6(phi), g6(tau)))
    write("sample.laos", "\n".join(lines) + "\n")


if __name__ == "__main__":
    generic_csv()
    generic_tsv()
    angle_sampled()
    strain_stress()
    anton_paar_en()
    anton_paar_de()
    anton_paar_fr()
    trios()
    reptate()
    anton_paar_fr_points()
    malvern()
    trios_csv()
    trios_lims()
    anton_paar_de_points()

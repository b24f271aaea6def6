"""The layout of the string kernels' arrays: their columns, kinds and sizes.

Constants only, no code: the columns of the per-string tables (``ipar``:
integer parameters and state, ``I_*``; ``fpar``: float parameters,
``F_*``; ``fst``: float state, ``S_*``), the probe channels (``P_*``),
the excitation kinds (``EXC_*``, the only place they are defined), the
bridge coupling's markers (``CPL_*``), the limits the tables are sized for
(``MAX_*``) and the layout of the fast path's scratch (``GROUP``,
``GROUP_CHUNK``, the rows ``_GROW``, ``_GIB``, ``_SCRATCH_GROUP`` and the
coupled groups' windows ``_CW``).  numba reads them as compile-time
constants of the kernels that import them.

The tables are written at note-on by the string bank
(:class:`synth.dsp.bank.StringBank`, the only code outside the kernels
that indexes them).  The kernels read them and write back only their
running state: the rings, every ``fst`` column, the ``ipar`` state columns
``I_POS``, ``I_EXC`` (an excitation ending: ``EXC_ENDED``, then
``EXC_NONE``), ``I_EXC_M`` and ``I_HLAST``, and the ``fpar`` column
``F_B0`` (the loss gain gliding towards ``F_B0T``);
:func:`synth.kernels.strings.scan_silence` also resets ``fst[:, S_PEAK]``
and writes its own outputs.  (:func:`synth.kernels.render.render_bank`
lowers a finer-grid string's ``I_ROW`` while it stages it, and restores
it.)  The sizes that follow from them (scratch lengths, chunk limits) are
plain Python in :mod:`synth.dsp.sizing`.

May import: nothing (every string kernel module imports this one).
"""

# ---- integer parameter columns (ipar[s, :]) ---------------------------------
I_OFF = 0        # ring offset in the flat ring array
I_N = 1          # cells N (ring length 2N)
I_POS = 2        # state: (time index of the last processed sample) mod 2N
I_K = 3          # excitation / pickup grid point k (1 .. N-1)
I_EXC = 4        # state: excitation kind, EXC_* below (0 none/ended, -1 ended with its
                 #   offset still to fold, 1-2 plucks, 3 g table, 4-6 felt hammers)
I_EXC_M = 5      # state: samples since excitation start (t = I_EXC_M * dt)
I_REG_OFF = 6    # offset of U(1..R) in the flat profile array
I_REG_N = 7      # R, points in the termination region (0: ideal rigid end)
I_SIDE = 8       # +1 obstacle above (u <= U), -1 below (u >= U)
I_FILT = 9       # 0 ideal far end, 1 loss + tuning filter
I_XDELAY = 10    # extra unit delay in the far-end filter (0 or 1)
I_OUT = 11       # output signal: 0 displacement u(k), 1 bridge force at x = L
I_PROBE = 12     # row in probe arrays, or -1
I_CHUNK = 13     # longest exact fast-path chunk (samples) while an excitation runs; 0: per-sample
I_EXC_END = 14   # first excitation sample with t > t0 (g constant from there);
                 #   g table: its length; hammer: latest end of the hammer's flight
I_GT_OFF = 15    # offset of the g table in the flat table array (kind 3)
I_HLAST = 16     # state: excitation sample of the hammer's last contact (-1: none yet)
I_NDISP = 17     # dispersion: number M of identical first-order allpass sections (0..MAX_DISP)
I_BOFF = 18      # offset of the pitch-bend delay line in the flat table array
I_BLEN = 19      # its length (0: no bend line)
I_CHUNK_FREE = 20  # the same with no excitation running (0 forces per-sample)
I_TELEM = 21     # 1: contact telemetry into the fst T_* columns (per-sample path), else 0
I_NSOS = 22      # dispersion: number of second-order allpass sections (0..MAX_SOS)
I_BUS = 23       # output buses: 0 bus 0 only; 1 split between buses 0 and 1 by F_PAN
I_CPL = 24       # bridge coupling: CPL_NONE; the leader slot of a coupled group (>= 0);
                 #   or CPL_EXTERNAL (the bridge's motion comes from the ``ubx`` array)
I_CPLN = 25      # strings in the coupled group (its leader's row counts them)
I_SUB = 26       # steps per engine sample (a finer grid: the string runs at I_SUB x the rate)
I_CPLNX = 27     # the next member of the coupled group after this one (-1: the last);
                 #   a group is the chain leader -> ... (any slots, not only consecutive)
I_ROW = 28       # first mix row of the string's buses: bus 0 to row I_ROW, bus 1 to I_ROW + 1
I_NI = 29

CPL_NONE = -1
CPL_EXTERNAL = -2
#: most strings in a coupled group by default (a piano key's unison); a bank
#: sized for more (``max_group``: a sitar's taraf and its played strings on one
#: bridge) holds :func:`coupled_scratch` samples more scratch
MAX_CPL = 4
#: finest grid: steps per engine sample
MAX_SUB = 8

# ---- excitation kinds (ipar[s, I_EXC]); the only place they are defined: the
# bank (synth.dsp.bank) and the voices' exciters use these names --------------
EXC_ENDED = -1   # ended on the last sample: its constant g is folded into the ring next
EXC_NONE = 0     # no excitation running
EXC_SITAR = 1    # kinematic pluck g(t) (eq. 1.13)
EXC_BIWA = 2     # force pluck g(t) (eq. 1.11); kinds <= EXC_BIWA have a closed-form g
EXC_GTABLE = 3   # g(t) from a table (the injected strike of Publication I)
EXC_HAMMER3 = 4  # felt hammer, three-parameter law (eq. 1.5); kinds >= EXC_HAMMER3 are hammers
EXC_HAMMER4 = 5  # felt hammer, four-parameter law (Pub. III eq. 3)
EXC_FELT = 6     # felt hammer, the felt as a medium (synth.kernels.felt_layer): its state in
                 #   the g table's place (I_GT_OFF); per-sample path only

# ---- float parameter columns (fpar[s, :]) -----------------------------------
F_DT = 0         # time step dt (s)
F_A = 1          # pluck amplitude A (m)
F_T0 = 2         # pluck duration t0 (s)
F_ALPHA = 3      # biwa alpha (1/s)
F_B0 = 4         # one-pole b0
F_A1 = 5         # one-pole a1   (y = b0 x - a1 y1)
F_ETA = 6        # allpass coefficient
F_GAIN = 7       # output gain (signal units -> mix units)
F_TDX = 8        # T / dx (N/m), bridge force scale
F_HMC = 9        # hammer: 2T / (c m) (1/s): its deceleration per unit g (mass m, string T, c)
F_HV = 10        # hammer speed V at first contact (m/s)
F_HQ = 11        # felt stiffness Q0 (3-par) or F0 (4-par), N/mm^p
F_HP = 12        # felt exponent p
F_HA = 13        # 3-par: alpha (s); 4-par: gamma
F_HT = 14        # 4-par: tau0 (s)
F_HK = 15        # hammer: c / 2T (m per N s): g increment per unit felt impulse
F_HE = 16        # 4-par hammer: exp(-dt / tau0)
F_HREL = 17      # samples without contact after which the hammer is gone
F_ADISP = 18     # dispersion allpass coefficient a (string stiffness)
F_B0T = 19       # target of the loss filter's b0: dampers and releases glide there
F_B0S = 20       # glide rate per sample (1 - exp(-dt / 2 ms)); an instant change of the
                 #   end's loss would step the bridge force (u(L) = x - y) and click
F_BDT = 21       # pitch bend: target delay of the bend line (samples, >= 1)
F_BDS = 22       # its glide rate per sample (20 ms: a pitch wheel moves, it does not jump)
# hammer constants of the step (:func:`_hammer_general`), set at each strike by
# the voice layer (synth.voices.bank.hammer_template): both felt laws in one
# form, the felt impulse over a step K int F dt = KCA y1 + KCBY y0 + KCBP Phi0
F_HDZ = 23       # dt T / (c m): z1 = z0 + dt V - dz (g0 + g1)
F_HD = 24        # 1 + dz: w1 = W0 - D x
F_HKCA = 25      # K ca (per unit y1)
F_HKCBY = 26     # K cb / y0
F_HKCBP = 27     # K cb / Phi0 (4-par only)
F_HKCD = 28      # K ca D p: Newton's derivative term
F_HPE = 29       # Phi1 = PE Phi0 + P1 y1 + P0 y0 (4-par; 0 for the 3-par law)
F_HP1 = 30
F_HP0 = 31
F_HFA = 32       # F1 = FA y1 + FB y0 + FPHI Phi1 (N)
F_HFB = 33
F_HFPHI = 34
F_HDTV = 35      # dt V (m): the hammer's free travel per step
F_HC2 = 36       # p (p - 1) / 2 and p (p - 1) (p - 2) / 6: Taylor terms of w^p
F_HC3 = 37
F_HB4 = 38       # binomial coefficients C(p, 4) .. C(p, 10) (F_HB4 + j = C(p, 4 + j))
F_TGAP = 45      # telemetry: contacts fewer than this many samples apart are one episode
# second-order dispersion allpasses (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2),
# after the tuning allpass: section j has c1 at F_SOS + 2 j, c2 at F_SOS + 2 j + 1
F_SOS = 46
MAX_SOS = 12
F_PAN = F_SOS + 2 * MAX_SOS   # share of the output on bus 1 (I_BUS = 1): (1 - pan) to bus 0
# the bridge of a coupled group (on its leader): u_b(n) = BRA u_b(n-1) + BRB F(n), with
# F(n) the strings' summed force on it (N), solved in the same sample (_bridge);
# BTDX = the members' summed T / dx (N/m)
F_BRA = F_PAN + 1
F_BRB = F_BRA + 1
F_BTDX = F_BRB + 1
F_UBOD = F_BTDX + 1   # external bridge: the offset S_UBOFF decays by this factor per sample
F_TOR = F_UBOD + 1    # pitch bend: the tune-out S_TO decays by this factor per sample
F_TOG = F_TOR + 1     # and the bend line reads F_TOG S_TO samples further back
F_HTOL = F_TOG + 1    # hammer solver: stop when a correction changes w by at most this,
                      #   relative (1e-5: the next would be ~1e-15; Halley's is cubic)
F_HTOLG = F_HTOL + 1  # or changes g by at most this, relative (1e-13 with 1e-5)
F_REACH = F_HTOLG + 1  # the region's reach: min over its points of side U(n) / n (m; 0: never
#                        out of reach; inf: no point can be touched), see _out_of_reach
F_CURV = F_REACH + 1   # sub-cell contact in the first cell (0: off; see _subcell_delta): the share
#                        of U(1) that is the profile's curvature, 1 - theta dx / U(1) (0 < value <= 1)
F_BRMU = F_CURV + 1   # the bridge's mass (coupled group, on its leader): mu = M / (R_b dt)
#                        (0: a dashpot, the old bridge; see _bridge)
# tension modulation (synth.kernels.tension; 0 in F_TMK: off, no operation):
F_TMK = F_BRMU + 1    # dT / T0 per unit of the ring's slope sum S (1/m^2): E A loop / (4 L T0 N dx),
#                        times string.tension_modulation
F_TML = F_TMK + 1     # the loop's delay at T0 (samples): the bend line reads F_TML (1 / sqrt(1 + x) - 1)
#                        samples less at dT / T0 = x
F_TMM = F_TML + 1     # samples between two readings of the tension (a whole number, >= 1)
F_TMA = F_TMM + 1     # a reading's weight in the smoothed slope sum (one pole, 0 < value <= 1)
F_NF = F_TMA + 1

# ---- float state columns (fst[s, :]) ----------------------------------------
S_G = 0          # current g (m)
S_LP = 1         # one-pole state
S_APX = 2        # allpass x[n-1]
S_APY = 3        # allpass y[n-1]
S_XD = 4         # extra-delay register
S_PEAK = 5       # peak |gain * signal| since last reset (silence detection)
S_HZ = 6         # hammer position z (m)
S_HY = 7         # felt y = w_mm^p at the last step
S_HPHI = 8       # 4-par: memory integral Phi (mm^p s)
S_HW = 9         # felt compression w at the last step (m)
S_BD = 10        # pitch bend: current delay of the bend line (samples)
S_BW = 11        # its write position
S_HDG = 12       # hammer: g increment of the last step (Newton's predictor)
S_D0 = 13        # dispersion sections' states: x1, y1 per section
MAX_DISP = 16
S_HDG2 = S_D0 + 2 * MAX_DISP   # hammer: g increment of the step before the last
S_HDG3 = S_HDG2 + 1   # and the one before that
S_HIW = S_HDG3 + 1    # hammer: 1 / w at the last step (1/m; 0 out of contact)
# contact telemetry (I_TELEM = 1), the same quantities as
# synth.analysis.contacts.contact_summary, accumulated sample by sample:
S_TC_N = S_HIW + 1    # samples with a termination point in contact
S_TC_EP = S_TC_N + 1  # termination contact episodes (runs F_TGAP or more samples apart)
S_TC_GAP = S_TC_EP + 1  # samples since the last termination contact (-1: none yet)
S_TC_PTS = S_TC_GAP + 1  # most termination points in contact at one sample
S_HC_N = S_TC_PTS + 1  # samples with the hammer felt pressing (F > 0)
S_HC_EP = S_HC_N + 1  # hammer contact episodes
S_HC_GAP = S_HC_EP + 1  # samples since the last hammer contact (-1: none yet)
S_HF_PK = S_HC_GAP + 1  # peak hammer force (N)
# second-order sections' states: x1, x2, y1, y2 per section (direct form I)
S_SOS = S_HF_PK + 1
S_UBW = S_SOS + 4 * MAX_SOS   # coupled group (leader): the bridge's last step w = u_b(i) - a u_b(i-1)
#                               (m; its velocity times dt: the state of its mass, F_BRMU > 0)
S_UBM = S_UBW + 1             # coupled group (leader): the bridge displacement of the last sample (m)
S_UBP = S_UBM + 1             # a string on a bridge: the bridge displacement of its last sample
S_UBOFF = S_UBP + 1           # a string on an external bridge: the offset its end eases off
S_TO = S_UBOFF + 1            # pitch bend: the tune-out, extra delay of the bend line (samples,
                              #   times F_TOG), decaying by F_TOR per sample (the contact's pitch
                              #   rise, undone)
S_U1P = S_TO + 1              # sub-cell contact (F_CURV > 0): u(1) at the last sample (m), after
                              #   point 1's clamp
S_TM = S_U1P + 1              # tension modulation: the bend line's delay change now (samples, <= 0)
S_TMS = S_TM + 1              # its smoothed slope sum (m^2)
S_TMC = S_TMS + 1             # samples until the next reading (>= 1; the bank sets F_TMM at note-on)
S_TMD = S_TMC + 1             # S_TM's step per sample: a reading's change spread over the samples to
#                               the next reading (samples per sample; 0: S_TM holds)
S_NS = S_TMD + 1

# ---- probe channels (probe[row, ch, n]) ---------------------------------------
P_U = 0          # u at the excitation point (m)
P_CONTACT = 1    # region points in contact with the termination
P_F = 2          # hammer force (N)
P_W = 3          # felt compression w (m)
P_Z = 4          # hammer position z (m)
P_G = 5          # outgoing wave g (m)
P_NCH = 6

# ---- the far end's free state (the hand-over between grids) ----------------
#: most free values of a far-end filter's state (:func:`hand_over_loop`):
#: the unit delay, the loss, the first-order sections' outputs, the tuning
#: allpass's, the first biquad's x2, two per biquad
MAX_FREE = 4 + MAX_DISP + 2 * MAX_SOS

# ---- the fast path's scratch ------------------------------------------------
#: hammered strings the fast path steps together (:func:`_render_group`)
GROUP = 4
#: their chunks' longest length (samples)
GROUP_CHUNK = 512
#: distance (samples) between the group's rows: 4288 bytes, 192 more than a
#: page, so that member m's row and member m+1's are not 4 KiB apart (a load
#: whose address matches an earlier store's in its low 12 bits waits for it:
#: "4K aliasing")
_GROW = GROUP_CHUNK + 24
#: excited strings a coupled group's fast-path chunk takes (their g rows, the
#: first GROUP of which also serve the hammers of :func:`_render_group`):
#: plucks last 3-4 ms at 325 kHz, so a chord or a strum struck within that
#: time on a sitar's bridge has that many members exciting at once, and with
#: more than this the whole group (taraf and every sounding string) steps
#: per sample until they end (the 128-note cluster of ``tools/bench.py live``
#: struck 0.4 ms apart has about 9 at once)
ROWS = 16
#: the rows of incoming waves start here (1088 bytes past a page multiple
#: from the g rows: (ROWS _GROW + 264) 8 = 17 pages + 1088 bytes)
_GIB = ROWS * _GROW + 264
#: scratch samples before the per-chunk windows (the group's g and I1 rows)
_SCRATCH_GROUP = _GIB + GROUP * _GROW + GROUP + 8
#: int64 work samples :func:`synth.kernels.render.render_bank` needs besides the
#: string list
IWORK_EXTRA = 6 * GROUP + ROWS
#: the coupled groups' far-end buffers at the end of ``scratch``: per member
#: x (C + 2) and y (C + 1) windows, and the bridge's row, for chunks of at most
#: GROUP_CHUNK samples
_CW = GROUP_CHUNK + 8

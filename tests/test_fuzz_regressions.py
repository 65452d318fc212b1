"""Regressions and cross-checks of the independent verdict campaign (benchmarks/fuzz_verdicts.py,
docs/benchmarks.md#independent-verdict-campaign).

The campaign compared exotune's verdicts on random designs far beyond the shipped examples with
references that share no code with exotune's analysis: the gains re-derived from the method page's double compliance shaping, the
controller assembled with python-control, the plant written from the physical equations; the
continuous loops decided by an argument-principle count of my own on the exact delay (plus
Newton's method on the exact characteristic function, and Padé 8/14 eigenvalues), the sampled
loops by eigenvalues of a zero-order-hold discretization (scipy ``cont2discrete``, fractional
delay split inside the period) of the controller file read with ``yaml.safe_load``.

* ``CONTINUOUS_CASES``: the members closest to the imaginary axis the campaign decided (the
  rightmost exact root at |Re s|/|s| ≈ 1e-8 … 1e-3: light masses whose cuff resonance is almost
  undamped, designs placed on the free-stability boundary, stiff environments), per loop kind.
* ``SAMPLED_CASES``: sampled-data members nearest |z| = 1 with fractional delays (ρ − 1 ≈ ±1e-7).
* Two defects the campaign found, both fixed and kept as regressions: the stable side of an
  interval end was not checked (an unstable window inside a reported stable interval; certify's
  intervals and the sweep's sampled columns), and an exported file certify could not read
  (6044f09).

Run time: about 10 s, plus 30 s for the export → certify round trip.
"""

from __future__ import annotations

import copy
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from campaign_designs import S22

ROOT = Path(__file__).resolve().parents[1]


def _reference():
    """benchmarks/fuzz_verdicts.py, the independent reference (loaded by path: benchmarks/ is not a package)."""
    name = "fuzz_verdicts_reference"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / "fuzz_verdicts.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
        pc = mod.pade_check()
        mod.PADE_X_OK = min(pc[8]["x_ok"], pc[14]["x_ok"])
    return sys.modules[name]


PK = ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia", "cuff_stiffness")
DK = ("amplification", "felt_inertia", "felt_damping", "zeta", "zeta_hat")


def _design(case: dict) -> tuple[dict, str]:
    """The design file mapping of a case (one family, or none for the free/locked loops) and the
    name of its loop in the reference's records."""
    im = case["impl"]
    impl = {"delay_s": im["delay_s"], "sample_rate_hz": im.get("sample_rate_hz"),
            "gv_filter": {"cutoff_hz": im["gv"][0], "damping": im["gv"][1]},
            "derivative_filter": {"cutoff_hz": im["fd"]},
            "dob": None if im["dob"] is None else {"cutoff_hz": im["dob"][0], "damping": im["dob"][1]}}
    if "vf" in im:
        impl["velocity_filter"] = {"cutoff_hz": im["vf"]}
    m = {"plant": dict(zip(PK, case["plant"])), "design": dict(zip(DK, case["design"])), "implementation": impl,
         "humans": [], "environment": [{"kind": "locked"}, {"kind": "free"}]}
    loop = case["loop"]
    if isinstance(loop, str):
        return m, loop
    fam = {k: v for k, v in loop.items() if k != "where"}
    if loop.get("where") == "environment":
        m["environment"].append(fam)
        return m, f"env0_{fam['kind']}"
    m["humans"].append(fam)
    return m, f"human0_{fam['kind']}"


def _member(case: dict, mapping: dict, x) -> dict | None:
    if x is None:
        return None
    fam = mapping["humans"][0] if mapping["humans"] else mapping["environment"][-1]
    (p,) = [k for k, v in fam.items() if isinstance(v, list)]
    return {p: x}


CONTINUOUS_CASES = [
    dict(plant=[0.02656626492374361, 31.892096150137707, 2971.5551255230134, 0.8575604994433147, 585.985048431206],
         design=[28.108828445061288, 0.18394636434661882, 0.10519273962249263, 0.226647209578542, 0.8641240951748536],
         impl={'delay_s': 0.008819229242793391, 'gv': [336.2578081883149, 1.3286756326716334], 'fd': 86.7949752799015, 'dob': None},
         loop={'kind': 'mass', 'inertia': [1.4418980618123586e-07, 7.4334861344896926e-06], 'damping': 0.0},
         members=[(1.6452054647373096e-07, False)]),
    dict(plant=[0.34824931755892297, 2.729399051692897, 18437.865738170025, 0.028556914315924994, 725969.44219514],
         design=[5.22092806677104, 0.11789641972579182, 0.10535440744374043, 0.23265047823554433, 0.3226113815930656],
         impl={'delay_s': 0.008513001834211295, 'gv': [137.81643448221763, 1.384012234356665], 'fd': 10.471918961995359, 'dob': [73.21554120039676, 1.4769742274491802], 'vf': 661.7577113255034},
         loop={'kind': 'mass', 'inertia': [1.0834602599901981e-05, 0.0018570611139640464], 'damping': 0.0},
         members=[(3.867659309250356e-05, False)]),
    dict(plant=[0.027972517156332557, 25.109427928073416, 3840.9935832525107, 0.9501043232366052, 536.9812340902484],
         design=[5.05762471273312, 0.8659951074053364, 0.371275607227641, 1.4400450304743135, 0.0617908586289292],
         impl={'delay_s': 0.007111383216666037, 'gv': [27.97379247512912, 1.1739261362055922], 'fd': 343.7789663511887, 'dob': None, 'vf': 27.827557376572425},
         loop={'kind': 'mass', 'inertia': [3.7623206155047937e-05, 0.019952932939861678], 'damping': 0.0},
         members=[(5.182903424143012e-05, False)]),
    dict(plant=[0.029950662898431825, 1.2509970466382347, 1655.2317218023106, 0.11964041277008211, 182053.07450142052],
         design=[4.382869040953508, 0.08045348420412253, 0.6079104901040973, 0.21007687365018543, 0.09837746588462777],
         impl={'delay_s': 0.003505496173869619, 'gv': [247.47101806143752, 1.4774153703393857], 'fd': 8.288328461270922, 'dob': None},
         loop={'kind': 'mass', 'inertia': [8.062016648142722e-06, 0.0001913833439823425], 'damping': 0.0},
         members=[(7.222466551577078e-05, True)]),
    dict(plant=[0.3226502529421322, 1.189502311386326, 215.26934824357508, 0.052469539338997, 744.4055357468062],
         design=[25.27291602390167, 0.5440368624263733, 0.2761382364713355, 0.9007115376546309, 1.09858821466604],
         impl={'delay_s': 0.011075474315860758, 'gv': [243.21188272165463, 0.3204900543457127], 'fd': 76.2605604136972, 'dob': None},
         loop={'kind': 'mass', 'inertia': [2.5271946035522847e-08, 8.944143966778559e-05], 'damping': 0.0},
         members=[(3.460616367746729e-07, False)]),
    dict(plant=[0.11574421650508107, 1.946584507633188, 2740.5118130296714, 0.03905472417701615, 468472.4045778634],
         design=[42.626867182543336, 0.022440990520043717, 0.8193718924459147, 0.22472572332431687, 0.06107193434887086],
         impl={'delay_s': 0.008493994633519407, 'gv': [32.55834386806782, 0.5554805616507085], 'fd': 6.528147938709665, 'dob': None},
         loop={'kind': 'mass', 'inertia': [8.955833649308378e-06, 0.0002420084150576266], 'damping': 0.0},
         members=[(7.773158111640632e-05, True)]),
    dict(plant=[0.34870430138456476, 11.175339987712114, 227.96385120039898, 0.04828768558616162, 89909.34781465837],
         design=[20.648746832469858, 0.13040278163842747, 0.18714167606018411, 1.095055178933651, 0.2906358979555103],
         impl={'delay_s': 0.011614336300610508, 'gv': [83.28732441676287, 1.401137333985518], 'fd': 48.0810769862424, 'dob': [5.82699715931229, 0.7106213546831732], 'vf': 197.4693132270741},
         loop={'kind': 'mass', 'inertia': [6.756165665425482e-06, 0.07326545572826891], 'damping': 0.0},
         members=[(5.686761676343632e-05, False)]),
    dict(plant=[0.1659642501876459, 4.999959409793675, 233.00906275814242, 0.8040905273468786, 648.0779410906943],
         design=[1.4595479685204258, 0.05369244329408192, 0.059111469166849215, 0.3859129559658226, 0.14739047497602742],
         impl={'delay_s': 0.0010742552192872764, 'gv': [172.23366924721938, 1.0064067202505131], 'fd': 540.4673118779867, 'dob': [5.644104904756533, 0.38096631464013475]},
         loop={'kind': 'mass', 'inertia': [1.747597915543427e-06, 9.385827873690405e-05], 'damping': 0.0},
         members=[(2.8941922252691475e-06, False)]),
    dict(plant=[0.2055906341265833, 0.3241427237329424, 4267.0131577673865, 1.3039335489250732, 12286.010332943291],
         design=[42.67623318915704, 0.007920351503528923, 0.14779678309928135, 0.15183539107700164, 0.1779334517368668],
         impl={'delay_s': 0.0034930704283056, 'gv': [253.68006422562493, 0.4537661081998265], 'fd': 29.661929400142643, 'dob': None, 'vf': 854.0353005061712},
         loop={'kind': 'mass', 'inertia': [6.394202891161157e-08, 8.201238733564223e-05], 'damping': 0.0},
         members=[(9.957958711164124e-07, False)]),
    dict(plant=[1.749611148566041, 9.973650722914389, 16253.22207284041, 0.02760987399390302, 455.5918972083791],
         design=[2.6194980944044213, 0.6419443411645727, 0.016261819911634237, 0.11907475069253962, 0.58217219757782],
         impl={'delay_s': 0.001138010393277965, 'gv': [112.09947208957121, 1.4038925870900445], 'fd': 154.01276727105105, 'dob': [40.676287998964526, 0.8492475543369427]},
         loop={'kind': 'mass', 'inertia': [2.2292873994690208e-07, 0.012093755511749167], 'damping': 0.0},
         members=[(5.156443951949366e-07, True)]),
    dict(plant=[0.059822839222066944, 9.257894107252827, 298.6177950670554, 0.05274001098184909, 43.81655416348738],
         design=[1.5350154571832535, 0.009175943202141228, 0.06088784393669336, 0.7176227613780806, 0.4173973680217303],
         impl={'delay_s': 0.00509585531306358, 'gv': [359.49055388255806, 0.5210023447596541], 'fd': 45.241332627683036, 'dob': [8.959095926480977, 0.7802565976858551], 'vf': 39.063882188519194},
         loop={'kind': 'spring', 'stiffness': [215.77340929637518, 704736.4360989518], 'damping': 0.0, 'where': 'environment'},
         members=[(508096.42726364254, True)]),
    dict(plant=[0.1447702367769482, 9.129787971486902, 3061.2956223714336, 0.09189713170121493, 4241.150579722853],
         design=[3.0822039222909794, 0.36227341103463845, 12.500634194659153, 0.5663721693901321, 0.07379599604100043],
         impl={'delay_s': 0.0006720317746520687, 'gv': [111.25291939051509, 1.0078519374124288], 'fd': 245.00420035977555, 'dob': [65.1356150650961, 1.2841253690897243]},
         loop={'kind': 'spring', 'stiffness': [960.3986736659111, 967305.3005738369], 'damping': 0.0, 'where': 'environment'},
         members=[(686941.8727064473, False)]),
    dict(plant=[0.16014985778366725, 1.431547886501377, 17527.5880725098, 0.034319694500721316, 1171.085946664839],
         design=[4.401970434991111, 0.14277159340718745, 27.86341287230289, 0.6003227258347354, 1.2792792263105384],
         impl={'delay_s': 0.003056560085119105, 'gv': [13.247982301863082, 1.4611370335038685], 'fd': 115.78362039145452, 'dob': [28.79418183851689, 1.235750144883095]},
         loop={'kind': 'spring', 'stiffness': [1.4846086431842642, 60.785024881809065], 'damping': 0.0},
         members=[(11.119050446328902, True)]),
    dict(plant=[0.16014985778366725, 1.431547886501377, 17527.5880725098, 0.034319694500721316, 1171.085946664839],
         design=[4.401970434991111, 0.14277159340718745, 27.86341287230289, 0.6003227258347354, 1.2792792263105384],
         impl={'delay_s': 0.003056560085119105, 'gv': [13.247982301863082, 1.4611370335038685], 'fd': 115.78362039145452, 'dob': [28.79418183851689, 1.235750144883095]},
         loop='free',
         members=[(None, False)]),
    dict(plant=[0.741636025647573, 10.787607978194908, 579.8678097920665, 0.548798105511155, 947755.0555749916],
         design=[1.1244483538632928, 0.5167817944427446, 4.476323893415587, 1.1721622607780766, 1.5185482022342316],
         impl={'delay_s': 0.0019352132642572939, 'gv': [19.70119451425663, 0.7824376576530687], 'fd': 5.00598500978754, 'dob': [141.8138772837795, 1.2734041196101262]},
         loop={'kind': 'msd', 'inertia': [0.0005316203777520155, 1.3037549827261907], 'damping': 0.12617681681774584, 'stiffness': 2.1877358209740247},
         members=[(0.2510695536797808, False)]),
    dict(plant=[0.11817656483796418, 52.1930510450819, 8888.22736424382, 0.6645680655385736, 27924.188734085343],
         design=[1.1684440524620363, 0.29356965890968784, 0.031250305261255294, 1.0996982017915256, 0.12521815235711217],
         impl={'delay_s': 0.004181489150311977, 'gv': [145.90470861227973, 0.8232989323847419], 'fd': 116.12333779235651, 'dob': [62.41338621029379, 0.38817999454765445]},
         loop={'kind': 'mass', 'inertia': [0.00450112726180382, 0.622617130689703], 'damping': 0.0, 'where': 'environment'},
         members=[(0.011595236311315227, False)]),
    dict(plant=[0.03237697276286441, 10.64208576948284, 4430.5671663587, 0.09264955490670393, 43968.553576621416],
         design=[1.5241571376780056, 0.010681046422362315, 0.6740264563602631, 1.5459433702882037, 1.603071520999844],
         impl={'delay_s': 0.001259039008104509, 'gv': [254.65451351636605, 1.2124132851955651], 'fd': 30.497407484551623, 'dob': None},
         loop={'kind': 'spring', 'stiffness': [0.6107805957278554, 915.9591450904239], 'damping': 0.0},
         members=[(26.002110429670505, True)]),
    dict(plant=[0.0367741430558095, 30.61229447728332, 8709.66445433566, 0.7919392164971378, 15175.648912685332],
         design=[8.093914674576766, 0.011452241293463608, 3.3097479478597345, 0.05192163373293043, 1.5281163210103246],
         impl={'delay_s': 0.010182715590927854, 'gv': [37.72787717596492, 0.34782937755158905], 'fd': 34.35431372362073, 'dob': [10.337973611087754, 0.83443847872431]},
         loop={'kind': 'mass', 'inertia': [0.0023802972141455277, 0.9103402739302223], 'damping': 0.0, 'where': 'environment'},
         members=[(0.28484152552742725, True)]),
    dict(plant=[0.0367741430558095, 30.61229447728332, 8709.66445433566, 0.7919392164971378, 15175.648912685332],
         design=[8.093914674576766, 0.011452241293463608, 3.3097479478597345, 0.05192163373293043, 1.5281163210103246],
         impl={'delay_s': 0.010182715590927854, 'gv': [37.72787717596492, 0.34782937755158905], 'fd': 34.35431372362073, 'dob': [10.337973611087754, 0.83443847872431]},
         loop='locked',
         members=[(None, True)]),
    dict(plant=[0.15704133273004786, 6.446087613671672, 19852.542831066658, 0.027687690256141668, 6733.892426256385],
         design=[2.4228637095961494, 0.19737080658717593, 27.345431915295507, 0.3215197986416607, 0.9228025865516001],
         impl={'delay_s': 0.0, 'gv': [243.5121674971252, 0.41937752647592663], 'fd': 50.72978786624756, 'dob': None, 'vf': 722.3272597669169},
         loop={'kind': 'spring', 'stiffness': [8.500432505931721, 2559.75679177667], 'damping': 0.0},
         members=[(8.500432505931721, False)]),
    dict(plant=[0.15704133273004786, 6.446087613671672, 19852.542831066658, 0.027687690256141668, 6733.892426256385],
         design=[2.4228637095961494, 0.19737080658717593, 27.345431915295507, 0.3215197986416607, 0.9228025865516001],
         impl={'delay_s': 0.0, 'gv': [243.5121674971252, 0.41937752647592663], 'fd': 50.72978786624756, 'dob': None, 'vf': 722.3272597669169},
         loop='free',
         members=[(None, True)]),
    dict(plant=[0.5454441272696914, 5.446076024818457, 1822.4958481983833, 1.2609975277185135, 12408.25141773853],
         design=[1.3143436706944915, 0.9337029315573306, 2.271026805446221, 0.05236378372286055, 0.7495361620274462],
         impl={'delay_s': 0.000835112716071503, 'gv': [185.08753089150042, 1.4519498304246725], 'fd': 133.07969670804027, 'dob': None, 'vf': 172.11096939913367},
         loop={'kind': 'msd', 'inertia': 0.1355338151791004, 'damping': [0.14077322618681423, 4.985833754313359], 'stiffness': 2.9453055169201616},
         members=[(1.2021394988446024, True)]),
    dict(plant=[0.03568843834294508, 4.004503012656706, 7372.607941279096, 0.03698386089966299, 22177.09140366029],
         design=[49.60601129731502, 0.4635022110970807, 0.43819614849167265, 0.07370583715051011, 0.3317138729512374],
         impl={'delay_s': 0.0035571247057027775, 'gv': [46.920335841247216, 0.7696052047490343], 'fd': 60.174280240249, 'dob': [12.148283469464237, 0.537043238265426]},
         loop={'kind': 'msd', 'inertia': [7.151851242760269e-05, 0.011965413351513222], 'damping': 0.09461657271589718, 'stiffness': 1.8933854094593296},
         members=[(0.011253515430075273, True)]),
    dict(plant=[0.641185032925007, 23.524407036360323, 4783.72903887388, 0.049017285123806056, 624.9241693270438],
         design=[7.0328827666028895, 0.08872875943058625, 0.28796049430865395, 0.2765006850689426, 0.5233382656242204],
         impl={'delay_s': 0.0037824821009897498, 'gv': [350.3577808659808, 0.3987604427597504], 'fd': 262.06113859860403, 'dob': [35.51644768373487, 0.8853995883959784]},
         loop='free',
         members=[(None, False)]),
    dict(plant=[0.2872957887351881, 59.597334955899704, 1464.6168343032296, 0.14036813136016865, 50.454982155349555],
         design=[8.868803408191152, 0.004849077547222776, 0.10733345831102287, 0.1489695741942366, 0.22084257582358005],
         impl={'delay_s': 0.001947414267900958, 'gv': [66.61243775860606, 0.4077048174795207], 'fd': 22.265472548460966, 'dob': None},
         loop='free',
         members=[(None, True)]),
    dict(plant=[0.07880529499745967, 2.733759174311336, 334.81053076041036, 0.1025446444885283, 3140.8122751729306],
         design=[28.022322413043984, 0.018689353586810366, 1.466467676149075, 0.06557809589879245, 0.08185025920058442],
         impl={'delay_s': 0.011001207308902115, 'gv': [113.22645584277603, 0.486464989494386], 'fd': 20.777022202709322, 'dob': [83.10249404976665, 1.4314022823648964]},
         loop='locked',
         members=[(None, False)]),
]

SAMPLED_CASES = [
    dict(plant=[0.0407967820915775, 0.3162559212804831, 12218.6505285116, 0.2282222695122531, 122.1362472917846],
         design=[2.0745119125737483, 0.060356793323809214, 0.026999856841073987, 0.20295430734102513, 0.06988305041719521],
         impl={'delay_s': 0.003137372734602138, 'sample_rate_hz': 1000.0, 'gv': [7.576504673544542, 1.3910338226690258], 'fd': 145.17870530872852, 'dob': None},
         loop={'kind': 'mass', 'inertia': [4.487875345945404e-06, 0.004385282360384005], 'damping': 0.13575665091179615},
         members=[(9.953803922611928e-05, False)]),
    dict(plant=[0.03760420940634334, 45.156003120192196, 6541.456245922774, 1.4381450148880408, 15671.88492792514],
         design=[4.926324027846725, 0.008594721227271462, 0.02963281613602793, 0.7678830336312729, 0.4768965716712872],
         impl={'delay_s': 0.010318018111987544, 'sample_rate_hz': 500.0, 'gv': [79.08165353117752, 0.3977776276362228], 'fd': 18.635230179997137, 'dob': None},
         loop={'kind': 'mass', 'inertia': [1e-07, 7.120250765674746e-05], 'damping': 0.0},
         members=[(1.3922625911602978e-05, True)]),
    dict(plant=[0.03248957581314792, 23.40715428369174, 9552.334011831033, 0.2973599091639439, 20.776265612731226],
         design=[2.9816772941116247, 0.033653622792580926, 0.01952735929351436, 0.3026849948953597, 1.4842833324208589],
         impl={'delay_s': 0.0009247427460693745, 'sample_rate_hz': 4000.0, 'gv': [36.485545677568986, 0.7337639829957778], 'fd': 47.43619601941598, 'dob': [36.303872383764634, 1.0204645141899196]},
         loop={'kind': 'mass', 'inertia': [1.1896394981184725e-05, 0.0008381990082917471], 'damping': 0.0},
         members=[(2.876029611546346e-05, True)]),
    dict(plant=[0.7960445498588834, 0.45972426075871664, 1347.5755458125552, 0.0691583804127431, 1.6458554696560053],
         design=[19.284992239703936, 0.13181094911049307, 0.11309936035736906, 0.3403204298027932, 0.10545122105208032],
         impl={'delay_s': 0.0009337330505815908, 'sample_rate_hz': 4000.0, 'gv': [34.24347836267447, 1.0635324818253626], 'fd': 10.62228307729594, 'dob': [8.686276077193265, 0.7265727220671778]},
         loop={'kind': 'mass', 'inertia': [0.0005896315199980368, 0.03564170868437711], 'damping': 0.0},
         members=[(0.015692168081193777, False)]),
]


def _id(case):
    loop = case["loop"] if isinstance(case["loop"], str) else case["loop"]["kind"]
    where = "env-" if isinstance(case["loop"], dict) and case["loop"].get("where") else ""
    return f"{where}{loop}-T{case['impl']['delay_s'] * 1e3:.2f}ms"


@pytest.mark.parametrize("case", CONTINUOUS_CASES, ids=[_id(c) for c in CONTINUOUS_CASES])
def test_continuous_verdicts_match_the_independent_reference(case):
    """exotune's batch core (free/locked verdicts, stable intervals) against the exact-delay
    reference at members within 1e-8…1e-3 (relative) of the imaginary axis; the reference must
    still decide them as the campaign did."""
    ref = _reference()
    mapping, loop = _design(case)
    ex = ref.exotune_continuous(mapping)
    K = ref.continuous_controller(mapping["plant"], mapping["design"], mapping["implementation"])
    T = float(mapping["implementation"]["delay_s"])
    for x, expected in case["members"]:
        member = _member(case, mapping, x)
        human, env = ref.loop_arguments(mapping, loop, member)
        r = ref.member_verdict(mapping["plant"], K, T, human, env)
        assert r["ref"] is expected, (loop, member, r)
        stable, conclusive = ref.exotune_member(ex, mapping, loop, member)
        assert conclusive and stable is expected, (loop, member, stable, conclusive, r)


def _controller_doc(mapping: dict) -> dict:
    """The controller file of a design at its rate, without the (slow) sampled predictions, as
    read back from YAML (the fast path of tests/controllerfile/conftest.py)."""
    from exotune.controllerfile import build_export, design_at_rate

    fs = float(mapping["implementation"]["sample_rate_hz"])
    doc = build_export(design_at_rate(copy.deepcopy(mapping), fs), fs, analyses=False)
    doc["predicted"] = {}
    return yaml.safe_load(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def _exotune_sampled_member(doc: dict, human, env):
    """exotune's sampled-data verdict of one member (the model of record certify's intervals
    are made of): (stable or None, spectral radius)."""
    from exotune.controllerfile.certify import as_controller_file, position_feedback
    from exotune.controllerfile.fileio import discrete_from_file, plant_from_file
    from exotune.sampled import loop_verdict

    cf = as_controller_file(doc)
    h = None if human is None else {"inertia": human["m"], "damping": human["b"], "stiffness": human["k"]}
    e = env if isinstance(env, str) else {"inertia" if env["m"] else "stiffness": env["m"] or env["k"], "damping": env["b"]}
    st, rho, _ = loop_verdict(plant_from_file(cf), discrete_from_file(cf), position_feedback(cf.controller), h, e)
    return st, rho


@pytest.mark.parametrize("case", SAMPLED_CASES, ids=[_id(c) for c in SAMPLED_CASES])
def test_sampled_verdicts_match_the_independent_reference(case):
    """exotune's sampled-data model of record against the discrete reference (the file's sos
    filters in python-control, the plant discretized with cont2discrete, the fractional delay
    split inside the period) at light-mass members with ρ − 1 ≈ ±1e-7, and the free and locked
    loops; spectral radii to 1e-8."""
    ref = _reference()
    mapping, loop = _design(case)
    doc = _controller_doc(mapping)
    checks = [(loop, _member(case, mapping, x), expected) for x, expected in case["members"]]
    checks += [("free", None, None), ("locked", None, None)]
    for name, member, expected in checks:
        human, env = ref.loop_arguments(mapping, name, member)
        st_ref, rho_ref, _ = ref.sampled_verdict(doc, human, env)
        if expected is not None:
            assert st_ref is expected, (name, member, rho_ref)
        st_ex, rho_ex = _exotune_sampled_member(doc, human, env)
        assert st_ex is st_ref and abs(rho_ex - rho_ref) < 1e-8, (name, member, rho_ex, rho_ref)


@pytest.mark.parametrize("path,value", [(p, v) for p, v in _reference().HOSTILE_DESIGN
                                        if not p.startswith("implementation.sample_rate_hz")])
def test_hostile_design_values_are_refused_naming_the_field(path, value):
    """NaN, ±inf, negative and zero masses and stiffnesses, huge values, malformed ranges:
    a ConfigError naming the field (the command line's exit 2 is checked by the campaign)."""
    from exotune.api import load_design
    from exotune.errors import ConfigError

    ref = _reference()
    doc = yaml.safe_load((ROOT / "examples" / "paper.yaml").read_text())
    doc["humans"].append({"kind": "msd", "inertia": [1e-3, 1.0], "damping": 0.5, "stiffness": 20.0})
    doc["humans"][2:3] = [{"kind": "complex_stiffness", "stiffness": [10.0, 1000.0], "eta": 0.2}]
    doc["environment"].append({"kind": "spring", "stiffness": [10.0, 1e4], "damping": 1.0})
    ref._set(doc, path, value)
    with pytest.raises(ConfigError) as e:
        load_design(doc)
    assert path.split(".")[0].split("[")[0] in str(e.value)


# ------------------------------------------------------------------------------------------------
# Defects found by the campaign, fixed: regressions
# ------------------------------------------------------------------------------------------------
S35 = dict(plant=[0.03760420940634334, 45.156003120192196, 6541.456245922774, 1.4381450148880408, 15671.88492792514],
           design=[4.926324027846725, 0.008594721227271462, 0.02963281613602793, 0.7678830336312729, 0.4768965716712872],
           impl={"delay_s": 0.010318018111987544, "sample_rate_hz": 500.0, "gv": [79.08165353117752, 0.3977776276362228],
                 "fd": 18.635230179997137, "dob": None},
           loop={"kind": "mass", "inertia": [1.1798108014659946e-05, 1.2642665110334118e-05], "damping": 0.0})
S35_UNSTABLE_MEMBER = 1.2354633845290227e-05   # ρ = 1 + 3.68e-7 by exotune's own loop_verdict and the reference


def test_certify_intervals_exclude_a_member_its_own_model_finds_unstable():
    """Campaign design s35 (seed 2026): 500 Hz, 5.159 samples of delay, an undamped light mass on
    a stiff cuff; its mass family [1e-7, 7.12e-5] was reported stable on [1.16645e-5, 1.26388e-5]
    although the member 1.23546e-5 has ρ = 1 + 3.68e-7 (exotune's own loop_verdict, the reference,
    and ``exotune simulate --scenario light-mass``: growing). Reduced: the family is the one grid
    cell [1.17981e-5, 1.26427e-5] (stable → unstable) of the original 96-point grid; certify's
    interval search with a two-point grid reports [1.17981e-5, 1.26388e-5] stable with no proven
    and no unresolved cell."""
    from exotune.controllerfile.certify import sampled_analysis

    ref = _reference()
    mapping, _ = _design(S35)
    doc = _controller_doc(mapping)
    doc["certify"] = {"humans": [S35["loop"]], "environment": []}
    st_ex, rho_ex = _exotune_sampled_member(doc, {"m": S35_UNSTABLE_MEMBER, "b": 0.0, "k": 0.0}, "free")
    st_ref, rho_ref, _ = ref.sampled_verdict(doc, {"m": S35_UNSTABLE_MEMBER, "b": 0.0, "k": 0.0}, "free")
    assert st_ex is False and st_ref is False and rho_ex > 1 + 3e-7 and rho_ref > 1 + 3e-7
    h = sampled_analysis(doc, points=2)["humans"][0]
    assert not any(a <= S35_UNSTABLE_MEMBER <= b for a, b in h["stable_intervals"]), h["stable_intervals"]
    assert h["edge_cells"] > 0 and h["stable_intervals"] and not h["robust"]


def test_sweep_sampled_intervals_exclude_the_same_member():
    """The sweep's batched engine (exotune.sampled.families, the ``sampled: true`` columns) on the
    same reduced family: its march over the stable side of the interval end finds the window too."""
    from exotune.config import batch_config, design_from_mapping
    from exotune.sampled.batch import BatchLoops, Loop
    from exotune.sampled.families import family_check

    mapping, _ = _design(S35)
    cfg = design_from_mapping(mapping)
    bl = BatchLoops(batch_config(cfg, {}), S35["impl"]["sample_rate_hz"])
    lo, hi = 1.1798108014659946e-05, 1.2642665110334118e-05
    chk = family_check(bl, [0], Loop("h", human={"damping": 0.0}, param="inertia"), lo, hi, points=2)
    (ivs,) = chk["stable_intervals"]
    assert ivs and not any(a <= S35_UNSTABLE_MEMBER <= b for a, b in ivs), ivs
    assert not chk["robust"][0]


def test_stable_intervals_check_the_stable_side_of_a_verdict_change():
    """The root cause of the test above on a one-eigenvalue family: |λ(v)| = 0.5 except an
    unstable window (1.45, 1.47) and v ≥ 1.9; the grid [1, √2, 2] has the verdict change in
    [√2, 2], where bisection converges to 1.9; [√2, 1.9] is reported stable although it holds
    the window. ``cell_bound`` is an honest oracle (True only for a cell without unstable
    members)."""
    from exotune.controllerfile.continuation import stable_intervals

    def unstable(v):
        return 1.45 < v < 1.47 or v >= 1.9

    spectrum = lambda v: np.array([1.5 if unstable(v) else 0.5])  # noqa: E731
    cell_bound = lambda a, b: (not (a < 1.47 and b > 1.45) and b < 1.9, 0.5)  # noqa: E731
    ivs, info = stable_intervals(spectrum, 1.0, 2.0, points=3, cell_bound=cell_bound)
    assert not any(a <= 1.46 <= b for a, b in ivs), (ivs, info)


# S22 (campaign_designs): a 500 Hz fuzzing design, fixed since 6044f09


def test_an_exported_controller_file_is_readable_by_certify(tmp_path, monkeypatch):
    """Campaign design s22 (seed 2026), reduced to its mass family: 500 Hz, 3 samples of delay,
    an undamped light mass, a refinement budget spent on ≈ 20 000 unresolved cells. Before
    6044f09 ``exotune export --allow-uncertified`` listed them all (1.33 MB) and ``exotune
    certify`` stopped at "cannot read file: too large (… the limit is 1 MiB)": the export →
    certify chain broke on a file exotune wrote itself (10 of the campaign's 40 sampled designs).
    The file must stay readable by certify's reader (``load_controller_file``, what certify reads
    the file with before any analysis: the analysis itself, ~60 s here, is not what broke), list
    at most 20 cells and count all of them. The refinement budget is cut to 3 000 values per
    family (from 20 000): it is still spent, on thousands of cells that listed in full would
    still be listed 150 times over the cap, at a seventh of the export's cost."""
    import exotune
    from exotune.controllerfile import continuation, load_controller_file
    from exotune.errors import ConfigError

    monkeypatch.setattr(continuation, "MAX_REFINED", 3000)

    src, out = tmp_path / "s22.yaml", tmp_path / "s22.controller.yaml"
    src.write_text(yaml.safe_dump(S22, sort_keys=False))
    exotune.export(str(src), out=str(out), allow_uncertified=True, require_latency_margin_s=0.0)
    try:
        doc = load_controller_file(out).to_dict()
    except ConfigError as e:
        raise AssertionError(f"certify cannot read the file export wrote ({out.stat().st_size} bytes): {e}") from None
    assert out.stat().st_size < 200_000

    def capped(node):  # every (count, listed) pair of the file's family analyses
        if isinstance(node, dict):
            if "unresolved_cells" in node:
                yield node["unresolved_cells"], len(node.get("unresolved", []))
            for v in node.values():
                yield from capped(v)
        elif isinstance(node, list):
            for v in node:
                yield from capped(v)

    pairs = list(capped(doc))
    assert pairs and max(c for c, _ in pairs) > 20, pairs  # the budget was spent: more cells than listed
    assert all(listed <= min(count, 20) for count, listed in pairs), pairs

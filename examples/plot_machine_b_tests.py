"""
The papers' heating and cooling tests, simulated
================================================

Tests I-VI of Machine B (001 Table 5-3) from the ``vmc-b`` preset: spindle at
4000 or 8000 rpm, heating and cooling phases, different ambient conditions.
The peak Y errors are compared with the paper's, and the effect of the
``tool_growth`` effect on Z after the spindle stops is shown.

Run: ``python examples/plot_machine_b_tests.py``
"""

# %%
import pandas as pd

from skthermal.datasets import make_machine_b_tests
from skthermal.simulate import DutyCycle, ThermalMachine, describe_effects

print(describe_effects()[["effect", "parameters"]].to_string(index=False))

runs = make_machine_b_tests(random_state=0)
meta = pd.DataFrame(runs.attrs["metadata"]).set_index("run")
peak = runs.groupby("run", sort=False)[["disp_x_um", "disp_y_um", "disp_z_um"]].agg(
    lambda s: s.abs().max()
)
peak["paper Y"] = meta["paper_max_disp_y_um"]
print(peak.round(1))

# %%
# Tool growth after the spindle stops: Z with and without the effect (without
# it, only still air cools the tool: it runs hotter while turning and does
# not grow after the stop).
machine = ThermalMachine.from_preset("vmc-b")
duty = DutyCycle.heat_cool(8000, heat_h=1, cool_h=1)
z = pd.DataFrame(
    {
        "with tool_growth": machine.simulate(duty, noise=False)["disp_z_um"],
        "tool in still air": machine.with_effects(remove="tool_growth").simulate(
            duty, noise=False
        )["disp_z_um"],
    }
)
print(z.iloc[[110, 120, 130, 140, 160]].round(2))

# %%
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, axes = plt.subplots(2, 3, figsize=(11, 5), sharey=True)
    for ax, (name, run) in zip(axes.ravel(), runs.groupby("run", sort=False)):
        ax.plot(run["time_s"] / 3600, run["disp_y_um"], label="Y")
        ax.plot(run["time_s"] / 3600, run["disp_z_um"], label="Z")
        ax.set_title(f"Test {name}: {meta.loc[name, 'description']}", fontsize=7)
        ax.set_xlabel("h")
    axes[0, 0].set_ylabel("µm")
    axes[0, 0].legend()
    fig.tight_layout()
    plt.show()

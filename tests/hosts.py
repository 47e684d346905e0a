"""Host scripts the FMU tests share: each runs in a fresh interpreter (``run_python``) and prints JSON."""

#: The knee FMU in libcosimpy: c = 40 N s/m, the extensor command stepped to argv[2] [Pa] at t = 0.1 s, 1 ms
#: steps until argv[3] [s]; prints {"ok": [two simulate_until results], "time": [...], "X": [...]}.
LIBCOSIM_KNEE_STEP = r"""
import json, sys
from libcosimpy.CosimEnums import CosimVariableType
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave
log_output_level(CosimLogLevel.WARNING)
fmu, pe1, stop = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
ms = 1_000_000  # libcosim counts time in nanoseconds
steps = int(round(stop * 1000))
execution = CosimExecution.from_step_size(step_size=ms)
index = execution.add_local_slave(local_slave=CosimLocalSlave(fmu_path=fmu, instance_name="knee"))
vr = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
execution.real_initial_value(index, vr["c"], 40.0)
observer = CosimObserver.create_time_series()
execution.add_observer(observer)
override = CosimManipulator.create_override()
execution.add_manipulator(override)
observer.start_time_series(index, vr["X"], CosimVariableType.REAL)
ok = [execution.simulate_until(100 * ms)]
override.slave_real_values(index, [vr["pe_cmd"]], [pe1])
ok.append(execution.simulate_until(steps * ms))
# from step 1: libcosimpy 0.0.6 trims its sample lists by counting zero step numbers, step 0 included
times, _, X = observer.time_series_real_samples(index, vr["X"], from_step=1, sample_count=steps)
print(json.dumps({"ok": ok, "time": [t / 1e9 for t in times], "X": list(X)}))
"""

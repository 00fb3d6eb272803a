"""`noalias`: the Numba option the spring passes' range functions compile with.

The elastic spring pass (physics/springs.py `_elastic_range`), the body
pass, the viscous pass and the contact pair forces run their groups
through one range function, a plain compiled loop: called on one thread
for small models and from the prange over a phase's groups for large
ones, so one compile serves both, and the prange's body is one call.  Numba outlines a
prange body into a function whose array arguments it marks `noalias`
(LLVM may then keep loaded values in registers across stores into other
arrays); a plain njit function has no such option, and the same loop
compiled without it stepped 13–38 % slower (benchmarks/results/compile.md).
`NOALIAS` adds the option, `noalias=True`, to Numba's CPU target: the
flag exists in numba.core.compiler.Flags and its lowering
(callconv.decorate_function), only the decorator's mapping is missing.
If a Numba release moves those internals, NOALIAS is empty and the range
functions compile as plain functions (the same numbers, slower).

The promise made by `noalias`: no two array arguments of the function
share memory that the function writes.  The passes' containers
(physics/arrays.py) hold distinct arrays (a State's fields, a Model's,
their copies); the prange bodies compiled from the same loops have
carried the same promise since the first threaded pass.
"""
try:
    from numba.core import cpu, options
    from numba.core.compiler import Flags

    if "noalias" not in Flags.options:          # pragma: no cover (an older or newer Numba)
        raise ImportError
    if not hasattr(cpu.CPUTargetOptions, "noalias"):
        cpu.CPUTargetOptions.noalias = options.TargetOptions.Mapping("noalias")
    NOALIAS = {"noalias": True}
except (ImportError, AttributeError):           # pragma: no cover
    NOALIAS = {}

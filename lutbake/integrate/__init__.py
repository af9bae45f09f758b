"""integrate: a bake plan integrated to RGB, band by band, on an OpenCL device or by numpy.

Stages, one module each:

* devices: the OpenCL devices of every registered runtime, named and ordered; the devices a selector
  names (``opencl_devices``, ``device_key``, ``device_label``, ``find_devices``, ``find_device``,
  ``candidate_devices``, ``Runtime``, ``runtime_of``).
* icd: Intel's CPU runtime registered with the ICD loader by a vendor folder the user exports
  (``write_vendor_folder``, ``intel_vendor_folder``, ``unregistered_intel``).
* program: kernels/*.cl and their constants built per device and precision; launches and buffers
  (``built_program``, ``device_program``, ``DeviceProgram``, ``Kernels``).
* series: the series and closed form's inputs, the plan over the grid, a band's passes (``SeriesStats``,
  ``BakePlan``, ``SeriesOnDevice``); direct: the direct quadrature (``DirectOnDevice``); pointwise: the
  kernels at given points (``kernel_reflectance``, ``kernel_stack_colour``).
* selfcheck: what a device passes before it bakes (``self_check_error``, ``SELF_CHECK_TOLERANCE``).
* opencl: the OpenCL integrator and the choice of integrator (``OpenCLBackend``, ``backend``,
  ``DeviceCannotRun``); numpy_path: the numpy integrator (``NumpyBackend``); bands: what both share
  (``PendingRows``, ``bake_rows_all``); survey: every device surveyed (``survey_devices``).
* batch: many points through the ground truth or the bake's integrator (``truth_colours``, ``fast_colours``).

The device is an argument (``backend(..., device=...)``, ``OpenCLBackend(device=...)``): a selector, a
pyopencl Device, or None for the default rule (docs/devices.md); nothing here reads or writes the
environment.
"""

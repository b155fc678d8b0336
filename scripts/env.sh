# Source this (`. scripts/env.sh`) to run rqr's tests on the device CI tests against.
# Building needs nothing from here (build.rs runs glslc itself); only sets what exists, so other
# systems keep their own Vulkan driver.
# Pin lavapipe (CPU) unless the caller chose drivers: it is the device CI tests against.
if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ] && [ -f /usr/share/vulkan/icd.d/lvp_icd.json ] && [ -z "${RQR_ANY_DRIVER:-}" ]; then
  export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.json
fi

# Source this (`. scripts/env.sh`) to build and test rqr against what scripts/setup-vulkan.sh installed.
# Only sets what exists, so other systems keep their own Vulkan driver and shaderc.
if [ -z "${SHADERC_LIB_DIR:-}" ] && [ -s /opt/rqr-shaderc/libshaderc_combined.a ]; then
  export SHADERC_LIB_DIR=/opt/rqr-shaderc
fi
# Pin lavapipe (CPU) unless the caller chose drivers: it is the device CI tests against.
if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ] && [ -f /usr/share/vulkan/icd.d/lvp_icd.json ] && [ -z "${RQR_ANY_DRIVER:-}" ]; then
  export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.json
fi

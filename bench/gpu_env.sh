# Sourced by the GPU benchmark scripts once they are in the repository root: unpacks the NVIDIA
# Vulkan driver carried in .gl (../shared/gpu/README.md) and points the Vulkan loader at it.
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json

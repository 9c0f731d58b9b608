#include "core/camera/camera.hpp"

namespace ums {

template class CameraT<float>;
template class CameraT<double>;

}  // namespace ums

#include "core/frontend/klt_template_cache.hpp"

#include <stdexcept>
#include <string>

namespace ums {

KltTemplateCache::KltTemplateCache(int slots, int levels, int units_per_level)
    : slots_(slots), levels_(levels), units_per_level_(units_per_level) {
  if (slots < 1 || levels < 1 || levels > 32 || units_per_level < 1) {
    throw std::invalid_argument("KltTemplateCache: slots " + std::to_string(slots) + ", levels " +
                                std::to_string(levels) + ", units per level " + std::to_string(units_per_level) +
                                " (each must be >= 1, levels <= 32)");
  }
  keys_.assign(static_cast<std::size_t>(slots), Key{});
  data_.assign(static_cast<std::size_t>(slots) * static_cast<std::size_t>(levels) *
                   static_cast<std::size_t>(units_per_level),
               std::int16_t{0});
}

std::int16_t* KltTemplateCache::block(int s, const ImagePyramid& pyramid, const Eigen::Vector2f& p, int level, bool* filled) {
  *filled = false;
  if (s < 0 || s >= slots_ || level < 0 || level >= levels_) return nullptr;
  Key& k = keys_[static_cast<std::size_t>(s)];
  // Positions compared bit for bit: the same float is the same point, anything else is not.
  if (k.pyramid != &pyramid || k.generation != pyramid.generation() || !(k.x == p.x()) || !(k.y == p.y())) {
    k = Key{&pyramid, pyramid.generation(), p.x(), p.y(), 0u};
  }
  *filled = ((k.filled >> level) & 1u) != 0;
  return data_.data() + (static_cast<std::size_t>(s) * static_cast<std::size_t>(levels_) + static_cast<std::size_t>(level)) *
                            static_cast<std::size_t>(units_per_level_);
}

}  // namespace ums

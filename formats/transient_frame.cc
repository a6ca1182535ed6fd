// Sets of products (transient_frame.h).
#include "transient/formats/transient_frame.h"

namespace transient {

ProductSet Products(std::initializer_list<Product> products) {
  ProductSet set;
  for (Product product : products) set.set(static_cast<int>(product));
  return set;
}

}  // namespace transient

#include "model/default_model.h"

#include <cstdlib>

namespace mm {

std::string default_model_dir() {
  const char* from_environment = std::getenv("MM_MODEL_DIR");
  if (from_environment != nullptr && from_environment[0] != '\0') return from_environment;
  return MM_SHIPPED_MODEL_DIR;
}

}  // namespace mm

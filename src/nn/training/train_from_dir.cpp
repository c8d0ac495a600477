// Separate translation unit so that code using only the in-memory overload does not need the
// dataset reader.
#include "core/error.h"
#include "nn/training/train.h"

namespace mosyn::nn {

TrainResult train(const TrainOptions& options, const TrainCallbacks& callbacks) {
  if (options.data_dir.empty()) throw Error("train: no dataset directory given");
  const data::Dataset dataset = data::Dataset::open(options.data_dir);
  return train(options, dataset, callbacks);
}

}  // namespace mosyn::nn

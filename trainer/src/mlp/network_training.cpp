// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/mlp/network_training.hpp"

#include <array>
#include <numeric>
#include <stdexcept>

#include "batch_gradients.hpp"
#include "imm/datasets/random.hpp"
#include "imm/math/lane_math.hpp"

namespace imm::trainer::mlp {

Network::Network(const std::vector<int>& sizes, Activation output, double output_scale,
                 double init_range, std::uint64_t seed)
    : output_scale_(output_scale) {
  if (sizes.size() < 2) throw std::invalid_argument("a network needs inputs and an output");
  datasets::Rng rng(seed);
  for (std::size_t i = 1; i < sizes.size(); ++i) {
    MlpLayer layer;
    layer.weights.resize(sizes[i], sizes[i - 1]);
    layer.bias.resize(sizes[i]);
    for (Eigen::Index r = 0; r < layer.weights.rows(); ++r) {
      for (Eigen::Index c = 0; c < layer.weights.cols(); ++c) {
        layer.weights(r, c) = rng.uniform(-init_range, init_range);
      }
      layer.bias(r) = rng.uniform(-init_range, init_range);
    }
    layer.activation = i + 1 == sizes.size() ? output : Activation::kSigmoid;
    layers_.push_back(std::move(layer));
  }
  (void)to_mlp();  // validates the shapes
  for (const auto& layer : layers_) {
    activations_.emplace_back(static_cast<std::size_t>(layer.weights.rows()));
    deltas_.emplace_back(static_cast<std::size_t>(layer.weights.rows()));
  }
}

Network::Network(const Mlp& mlp) : layers_(mlp.layers()), output_scale_(mlp.output_scale()) {
  for (const auto& layer : layers_) {
    activations_.emplace_back(static_cast<std::size_t>(layer.weights.rows()));
    deltas_.emplace_back(static_cast<std::size_t>(layer.weights.rows()));
  }
}

void Network::forward(const double* input) const {
  const double* x = input;
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const MlpLayer& layer = layers_[l];
    const Eigen::Index rows = layer.weights.rows(), cols = layer.weights.cols();
    std::vector<double>& a = activations_[l];
    const double* w = layer.weights.data();  // column-major
    for (Eigen::Index r = 0; r < rows; ++r) a[static_cast<std::size_t>(r)] = layer.bias(r);
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double xc = x[c];
      const double* column = w + c * rows;
      for (Eigen::Index r = 0; r < rows; ++r) a[static_cast<std::size_t>(r)] += column[r] * xc;
    }
    for (Eigen::Index r = 0; r < rows; ++r) {
      a[static_cast<std::size_t>(r)] = activate(layer.activation, a[static_cast<std::size_t>(r)]);
    }
    x = a.data();
  }
}

double Network::predict(const double* input) const {
  forward(input);
  return output_scale_ * activations_.back()[0];
}

double Network::mse(const Samples& samples) const {
  double sum = 0.0;
  std::vector<double> row(static_cast<std::size_t>(samples.inputs.cols()));
  for (Eigen::Index i = 0; i < samples.inputs.rows(); ++i) {
    for (Eigen::Index c = 0; c < samples.inputs.cols(); ++c)
      row[static_cast<std::size_t>(c)] = samples.inputs(i, c);
    const double error = predict(row.data()) - samples.targets(i);
    sum += error * error;
  }
  return samples.inputs.rows() > 0 ? sum / static_cast<double>(samples.inputs.rows()) : 0.0;
}

void Network::gradients(const Samples& samples, std::vector<Eigen::MatrixXd>& weights,
                        std::vector<Eigen::VectorXd>& biases) const {
  // The whole batch at once: every layer's activations as an n × units matrix, so the work is
  // a handful of matrix products (Eigen's GEMM) and element-wise sigmoids (Eigen's vectorized
  // exp) instead of a loop over samples. Workspace persists between calls: no allocation after
  // the first epoch.
  if (has_shape(layers_, 2, 10, 10)) {
    fused_gradients_2_10_10(layers_, output_scale_, samples.inputs, samples.targets, weights,
                            biases);
    return;
  }
  gradients_general(samples, weights, biases);
}

void Network::gradients_general(const Samples& samples, std::vector<Eigen::MatrixXd>& weights,
                                std::vector<Eigen::VectorXd>& biases) const {
  const std::size_t layers = layers_.size();
  const Eigen::Index n = samples.inputs.rows();
  weights.resize(layers);
  biases.resize(layers);
  batch_activations_.resize(layers);
  batch_deltas_.resize(layers);
  const Eigen::MatrixXd* x = &samples.inputs;
  for (std::size_t l = 0; l < layers; ++l) {
    const MlpLayer& layer = layers_[l];
    Eigen::MatrixXd& a = batch_activations_[l];
    a.resize(n, layer.weights.rows());
    a.noalias() = *x * layer.weights.transpose();
    a.rowwise() += layer.bias.transpose();
    if (layer.activation == Activation::kSigmoid) {
      a = (1.0 + (-a.array()).exp()).inverse().matrix();
    }
    x = &a;
  }
  // Output delta of mean ½(a_L − t/scale)², the 1/n folded in here.
  const std::size_t last = layers - 1;
  const double inverse_n = n > 0 ? 1.0 / static_cast<double>(n) : 0.0;
  {
    const Eigen::MatrixXd& a = batch_activations_[last];
    Eigen::MatrixXd& d = batch_deltas_[last];
    d.resize(n, a.cols());
    d.col(0) = (a.col(0) - samples.targets / output_scale_) * inverse_n;
    if (layers_[last].activation == Activation::kSigmoid) {
      d.array() *= a.array() * (1.0 - a.array());
    }
  }
  for (std::size_t l = last + 1; l-- > 0;) {
    const Eigen::MatrixXd& below = l == 0 ? samples.inputs : batch_activations_[l - 1];
    const Eigen::MatrixXd& d = batch_deltas_[l];
    weights[l].resize(layers_[l].weights.rows(), layers_[l].weights.cols());
    weights[l].noalias() = d.transpose() * below;
    biases[l] = d.colwise().sum().transpose();
    if (l == 0) break;
    Eigen::MatrixXd& d_below = batch_deltas_[l - 1];
    d_below.resize(n, layers_[l].weights.cols());
    d_below.noalias() = d * layers_[l].weights;
    if (layers_[l - 1].activation == Activation::kSigmoid) {
      d_below.array() *= below.array() * (1.0 - below.array());
    }
  }
}

namespace {

// update_on_sample for a network of I inputs, two sigmoid hidden layers of H1 and H2 units and one
// output, with the sizes known to the compiler: the loops of the general path below, in the same
// order and with the same operations (so the same bits), unrolled and kept in registers. The
// input estimator's 2-10-10-1 network (seed 001, Fig. 2) spends most of a step in the general
// path's loop control.
template <int I, int H1, int H2>
void update_fixed(std::vector<MlpLayer>& layers, double output_scale, const double* input,
                  double target, double hidden_rate, double output_rate) {
  double* w1 = layers[0].weights.data();  // column-major, H1 × I
  double* w2 = layers[1].weights.data();  // H2 × H1
  double* w3 = layers[2].weights.data();  // 1 × H2
  double* b1 = layers[0].bias.data();
  double* b2 = layers[1].bias.data();
  double* b3 = layers[2].bias.data();
  const Activation output = layers[2].activation;
  std::array<double, H1> a1{};
  std::array<double, H2> a2{};
  for (int r = 0; r < H1; ++r) a1[r] = b1[r];
  for (int c = 0; c < I; ++c) {
    for (int r = 0; r < H1; ++r) a1[r] += w1[c * H1 + r] * input[c];
  }
  for (int r = 0; r < H1; ++r) a1[r] = activate(Activation::kSigmoid, a1[r]);
  for (int r = 0; r < H2; ++r) a2[r] = b2[r];
  for (int c = 0; c < H1; ++c) {
    for (int r = 0; r < H2; ++r) a2[r] += w2[c * H2 + r] * a1[c];
  }
  for (int r = 0; r < H2; ++r) a2[r] = activate(Activation::kSigmoid, a2[r]);
  double a3 = b3[0];
  for (int c = 0; c < H2; ++c) a3 += w3[c] * a2[c];
  a3 = activate(output, a3);

  const double d3 = (a3 - target / output_scale) * activation_derivative(output, a3);
  std::array<double, H2> d2{};
  for (int c = 0; c < H2; ++c) {
    double sum = 0.0;
    sum += w3[c] * d3;
    d2[c] = sum * activation_derivative(Activation::kSigmoid, a2[c]);
  }
  for (int c = 0; c < H2; ++c) w3[c] -= d3 * (output_rate * a2[c]);
  b3[0] -= output_rate * d3;
  std::array<double, H1> d1{};
  for (int c = 0; c < H1; ++c) {
    double sum = 0.0;
    for (int r = 0; r < H2; ++r) sum += w2[c * H2 + r] * d2[r];
    d1[c] = sum * activation_derivative(Activation::kSigmoid, a1[c]);
  }
  for (int c = 0; c < H1; ++c) {
    const double xc = hidden_rate * a1[c];
    for (int r = 0; r < H2; ++r) w2[c * H2 + r] -= d2[r] * xc;
  }
  for (int r = 0; r < H2; ++r) b2[r] -= hidden_rate * d2[r];
  for (int c = 0; c < I; ++c) {
    const double xc = hidden_rate * input[c];
    for (int r = 0; r < H1; ++r) w1[c * H1 + r] -= d1[r] * xc;
  }
  for (int r = 0; r < H1; ++r) b1[r] -= hidden_rate * d1[r];
}

// The input estimator's shape, with the lane kernels' clones: the same loops on wider vectors.
[[gnu::flatten]] IMM_VECTOR_CLONES void update_2_10_10(std::vector<MlpLayer>& layers,
                                                       double output_scale, const double* input,
                                                       double target, double hidden_rate,
                                                       double output_rate) {
  update_fixed<2, 10, 10>(layers, output_scale, input, target, hidden_rate, output_rate);
}

}  // namespace

void Network::update_on_sample(const double* input, double target, double hidden_rate,
                               double output_rate) {
  if (has_shape(layers_, 2, 10, 10)) {
    update_2_10_10(layers_, output_scale_, input, target, hidden_rate, output_rate);
    return;
  }
  update_general(input, target, hidden_rate, output_rate);
}

void Network::update_general(const double* input, double target, double hidden_rate,
                             double output_rate) {
  forward(input);
  const std::size_t last = layers_.size() - 1;
  deltas_[last][0] = (activations_[last][0] - target / output_scale_) *
                     activation_derivative(layers_[last].activation, activations_[last][0]);
  for (std::size_t l = last + 1; l-- > 0;) {
    MlpLayer& layer = layers_[l];
    const Eigen::Index rows = layer.weights.rows(), cols = layer.weights.cols();
    const double* x = l == 0 ? input : activations_[l - 1].data();
    // The deltas of the layer below use the weights before this update.
    if (l > 0) {
      for (Eigen::Index c = 0; c < cols; ++c) {
        double sum = 0.0;
        for (Eigen::Index r = 0; r < rows; ++r)
          sum += layer.weights(r, c) * deltas_[l][static_cast<std::size_t>(r)];
        deltas_[l - 1][static_cast<std::size_t>(c)] =
            sum * activation_derivative(layers_[l - 1].activation,
                                        activations_[l - 1][static_cast<std::size_t>(c)]);
      }
    }
    const double rate = l == last ? output_rate : hidden_rate;
    double* w = layer.weights.data();
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double xc = rate * x[c];
      double* column = w + c * rows;
      for (Eigen::Index r = 0; r < rows; ++r)
        column[r] -= deltas_[l][static_cast<std::size_t>(r)] * xc;
    }
    for (Eigen::Index r = 0; r < rows; ++r)
      layer.bias(r) -= rate * deltas_[l][static_cast<std::size_t>(r)];
  }
}

std::vector<LossPoint> train(Network& network, const Samples& training, const Samples& validation,
                             const TrainingOptions& options) {
  std::vector<LossPoint> curve;
  // Each point of the curve as it is measured (the live progress of `imm-train mlp`).
  const auto record = [&](int at) {
    curve.push_back({at, network.mse(training), network.mse(validation)});
    if (options.on_point) options.on_point(curve.back());
  };
  record(0);
  const auto n = static_cast<std::size_t>(training.inputs.rows());
  const auto columns = static_cast<std::size_t>(training.inputs.cols());
  // Row-major copy for fast per-sample access.
  std::vector<double> rows(n * columns);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < columns; ++c) {
      rows[i * columns + c] =
          training.inputs(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c));
    }
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  datasets::Rng rng(options.seed);
  std::vector<Eigen::MatrixXd> grad_w, moment_w, second_w;
  std::vector<Eigen::VectorXd> grad_b, moment_b, second_b;
  int epoch = 0;
  long adam_step = 0;
  for (const Phase& phase : options.phases) {
    for (int e = 0; e < phase.epochs; ++e) {
      ++epoch;
      if (options.mode == UpdateMode::kPerSample) {
        for (std::size_t i = n; i > 1; --i)
          std::swap(order[i - 1], order[rng.below(i)]);  // Fisher–Yates
        for (std::size_t i : order) {
          network.update_on_sample(rows.data() + i * columns,
                                   training.targets(static_cast<Eigen::Index>(i)),
                                   phase.hidden_rate, phase.output_rate);
        }
      } else {
        network.gradients(training, grad_w, grad_b);
        auto& layers = network.layers();
        if (options.optimizer == Optimizer::kAdam) {
          constexpr double kBeta1 = 0.9, kBeta2 = 0.999, kEpsilon = 1e-8;
          if (moment_w.empty()) {
            for (std::size_t l = 0; l < layers.size(); ++l) {
              moment_w.push_back(Eigen::MatrixXd::Zero(grad_w[l].rows(), grad_w[l].cols()));
              second_w.push_back(moment_w.back());
              moment_b.push_back(Eigen::VectorXd::Zero(grad_b[l].size()));
              second_b.push_back(moment_b.back());
            }
          }
          ++adam_step;
          const double c1 = 1.0 - std::pow(kBeta1, static_cast<double>(adam_step));
          const double c2 = 1.0 - std::pow(kBeta2, static_cast<double>(adam_step));
          for (std::size_t l = 0; l < layers.size(); ++l) {
            const double rate = l + 1 == layers.size() ? phase.output_rate : phase.hidden_rate;
            moment_w[l] = kBeta1 * moment_w[l] + (1.0 - kBeta1) * grad_w[l];
            second_w[l] = kBeta2 * second_w[l] + (1.0 - kBeta2) * grad_w[l].cwiseAbs2();
            moment_b[l] = kBeta1 * moment_b[l] + (1.0 - kBeta1) * grad_b[l];
            second_b[l] = kBeta2 * second_b[l] + (1.0 - kBeta2) * grad_b[l].cwiseAbs2();
            layers[l].weights.array() -=
                rate * (moment_w[l].array() / c1) / ((second_w[l].array() / c2).sqrt() + kEpsilon);
            layers[l].bias.array() -=
                rate * (moment_b[l].array() / c1) / ((second_b[l].array() / c2).sqrt() + kEpsilon);
          }
        } else {
          for (std::size_t l = 0; l < layers.size(); ++l) {
            const double rate = l + 1 == layers.size() ? phase.output_rate : phase.hidden_rate;
            layers[l].weights -= rate * grad_w[l];
            layers[l].bias -= rate * grad_b[l];
          }
        }
      }
      if (epoch % options.loss_every == 0) {
        record(epoch);
      }
    }
  }
  if (curve.back().epoch != epoch) record(epoch);
  return curve;
}

}  // namespace imm::trainer::mlp

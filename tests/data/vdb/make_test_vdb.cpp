// Writes the OpenVDB test files of tests/volume.rs with OpenVDB itself (Debian 12:
// apt-get install libopenvdb-dev), and next to each the values OpenVDB reads back:
//   g++ -O1 -std=c++17 make_test_vdb.cpp -o /tmp/make_test_vdb -lopenvdb -ltbb -lImath-3_1 && /tmp/make_test_vdb
// (run in this folder). Python's pyopenvdb cannot choose the compression (it always
// writes Blosc), hence C++.
//   small_zip.vdb    zlib + active-mask compression (OpenVDB's flags 3)
//   small_raw.vdb    active-mask compression only, values stored raw (flags 2)
//   small_blosc.vdb  Blosc (flags 6): rdr refuses it with a message
// Grids: "density" (float; voxels in two leaves and one active 8³ tile; a uniform
// scale and translation), "temperature" (float saved as half; a rotation: an affine
// map), "velocity" (vec3s, which rdr refuses). expected.txt: for sample index points,
// the grid name, the world position of the voxel centre and OpenVDB's value there.
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <cstdio>
#include <vector>

using namespace openvdb;

static GridPtrVec grids() {
    FloatGrid::Ptr density = FloatGrid::create(0.0f);
    density->setName("density");
    auto acc = density->getAccessor();
    for (int z = 0; z < 3; ++z)
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 5; ++x)
                acc.setValue(Coord(x + 6, y - 2, z + 1), 0.1f * float(1 + x + 10 * y + 100 * z));
    // an inactive voxel with a value of its own and one far away in another leaf
    acc.setValueOff(Coord(7, 0, 2), 0.25f);
    acc.setValue(Coord(20, 3, -5), 4.5f);
    density->tree().addTile(/*level=*/1, Coord(-16, 0, 0), 2.0f, /*active=*/true);
    math::Transform::Ptr t = math::Transform::createLinearTransform(0.25);
    t->postTranslate(Vec3d(1.0, -0.5, 2.0));
    density->setTransform(t);

    FloatGrid::Ptr temperature = FloatGrid::create(0.0f);
    temperature->setName("temperature");
    temperature->setSaveFloatAsHalf(true);
    auto tacc = temperature->getAccessor();
    for (int i = 0; i < 10; ++i) tacc.setValue(Coord(i, 2 * i, -i), 0.5f + float(i));
    math::Transform::Ptr r = math::Transform::createLinearTransform(0.5);
    r->postRotate(0.4, math::Y_AXIS);
    r->postTranslate(Vec3d(0.0, 1.0, 0.0));
    temperature->setTransform(r);

    Vec3SGrid::Ptr velocity = Vec3SGrid::create(Vec3s(0.0f));
    velocity->setName("velocity");
    velocity->getAccessor().setValue(Coord(1, 2, 3), Vec3s(1, 2, 3));
    return {density, temperature, velocity};
}

int main() {
    initialize();
    GridPtrVec g = grids();
    const struct { const char* name; uint32_t flags; } files[] = {
        {"small_zip.vdb", io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK},
        {"small_raw.vdb", io::COMPRESS_ACTIVE_MASK},
        {"small_blosc.vdb", io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK},
    };
    for (const auto& f : files) {
        io::File file(f.name);
        file.setCompression(f.flags);
        file.write(g);
        file.close();
    }
    // read one back with OpenVDB and record the values it gives
    io::File in("small_zip.vdb");
    in.open();
    FILE* out = std::fopen("expected.txt", "w");
    std::fprintf(out, "# grid  world x y z of a voxel centre  value (OpenVDB %s reading small_zip.vdb)\n", in.version().c_str());
    for (const char* name : {"density", "temperature"}) {
        FloatGrid::Ptr grid = gridPtrCast<FloatGrid>(in.readGrid(name));
        auto acc = grid->getConstAccessor();
        std::vector<Coord> at;
        for (int z = -18; z <= 9; z += 3)
            for (int y = -3; y <= 21; y += 3)
                for (int x = -17; x <= 22; x += 3) at.push_back(Coord(x, y, z));
        for (int i = 0; i < 10; ++i) at.push_back(Coord(i, 2 * i, -i));
        for (int i = 0; i < 7; ++i) at.push_back(Coord(i + 5, 0, 2));
        at.push_back(Coord(20, 3, -5));
        for (const Coord& c : at) {
            Vec3d w = grid->indexToWorld(c);
            std::fprintf(out, "%s %.9g %.9g %.9g %.9g\n", name, w.x(), w.y(), w.z(), acc.getValue(c));
        }
    }
    std::fclose(out);
    in.close();
    return 0;
}
